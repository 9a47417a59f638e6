"""The grounding core: diagnosis → refactoring unit → infiller → validation → executor."""
