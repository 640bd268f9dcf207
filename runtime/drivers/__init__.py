"""Serving a device driver: standard routes, state streaming, DNS-SD advertisement."""
