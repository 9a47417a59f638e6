"""Robot descriptions: data below the ontology.

One YAML file per embodiment API (``robots/<api>.yaml``, or a directory on ``RECENT_ROBOTS``):
the row (``embodiment:`` and ``robot:``: the robosuite models and MJCF files), the primitive API
the ontology reads, and its frames. Bundled robots and a user's robots share this one format.
Nothing here imports the simulator or changes the process on import.
"""
