"""The service kit shared by every service and device driver."""
