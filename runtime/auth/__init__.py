"""Who may use the runtime: users and their roles, sessions, API tokens and the audit log."""
