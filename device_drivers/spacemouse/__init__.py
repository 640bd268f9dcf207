"""3Dconnexion SpaceMouse as an input device: read with hidapi (or from spacenavd's socket),
reports parsed into six axes in [-1, 1] and buttons, served and advertised like any device."""
