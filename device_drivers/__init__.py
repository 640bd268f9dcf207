"""Device drivers, one package each, every one runnable as its own process."""
