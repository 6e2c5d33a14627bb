"""Mission items per autopilot and their file formats."""
