"""OpenPendant runtime: the service kit, standard device interfaces, services and launcher."""

__version__ = "0.1.0"
