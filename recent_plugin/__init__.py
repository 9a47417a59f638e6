"""RECENT as a LeRobot policy plugin: ontology-guided FIM grounding of robot skill code."""
