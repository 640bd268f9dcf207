"""Device manager: discovery, the registry of added devices, connections and live state."""
