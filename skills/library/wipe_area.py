def wipe_area(env, task, area="stain"):
    """Wipe the marked area in four strokes, fingertips 2 cm above it: off the table despite sensing noise."""
    area_pos = task.get_object_position(area)
    for dy in [-0.045, -0.015, 0.015, 0.045]:
        push(
            env,
            task,
            start_pos=[area_pos[0] - 0.09, area_pos[1] + dy, area_pos[2] + 0.02],
            target_pos=[area_pos[0] + 0.09, area_pos[1] + dy, area_pos[2] + 0.02],
            approach_axis="z",
        )
