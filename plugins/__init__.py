"""The plugin API (entry-point group `openpendant.plugins`). No plugin hooks exist yet; the
first issue that needs one adds it here."""
