"""The runtime's links to its devices: one per device, held by the device manager, used by
every service through its link socket (`openpendant.runtime.links.hub`)."""
