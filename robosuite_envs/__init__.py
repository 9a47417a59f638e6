"""The world RECENT is tested in: robosuite embodiments, their primitive APIs, tasks, and envs."""
