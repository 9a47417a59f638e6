"""Authoring skills: validating a reference skill by running it in simulation, and generating one.

Both run whole episodes through the agent, so this layer sits above it; what they write (skills
and their validation records) lives in ``skills/``, below grounding.
"""
