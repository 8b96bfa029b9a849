"""The service layer: the only code that writes the database or drives live missions."""
