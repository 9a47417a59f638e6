"""Run-time grounding: checks from undetermined warnings, in-situ patches, reactive repair."""
