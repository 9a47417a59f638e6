"""LeRobot plugin entry point."""
