"""The world RECENT is tested in: robosuite embodiments, their primitive APIs, tasks, and envs."""

from lerobot_policy_recent.robosuite_envs.runtime import configure_headless_gl, quiet_robosuite

configure_headless_gl()
quiet_robosuite()
