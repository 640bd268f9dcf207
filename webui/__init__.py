"""The web UI: the server (one origin for the UI and /api) and the front end (a Vite app)."""
