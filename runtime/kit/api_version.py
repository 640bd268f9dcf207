"""The version of the device API (routes, states, discovery records) a driver speaks: in
every device's identity and discovery record. A module of its own, so the interfaces (and
the robotics core under them) need not import the discovery machinery for one string."""

API_VERSION = "1"
