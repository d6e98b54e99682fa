"""representations layer."""
