"""Standard device interfaces (DESIGN.md §4): pydantic models and abstract driver classes."""
