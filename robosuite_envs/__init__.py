"""The world RECENT is tested in: robosuite tasks and envs, the simulator side of the primitive APIs.

Importing this package changes nothing in the process. The modules that load robosuite import
``runtime`` first, which picks a headless OpenGL backend and quiets robosuite before it loads.
"""
