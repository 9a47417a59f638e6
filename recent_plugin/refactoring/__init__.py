"""The refactoring unit: the span a conflict cuts out of a skill, its hints, and its FIM prompt.

It sits between the ontology's diagnosis and the infillers, which fill it; grounding, in-situ
adaptation and the baselines cut units and hand them to an infiller.
"""
