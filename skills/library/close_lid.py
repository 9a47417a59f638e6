def close_lid(env, task, lid="lid", container="jar"):
    """Pick the loose lid by its knob and set it centred on the container's rim."""
    lid_pos = task.get_object_position(lid)
    jar_pos = task.get_object_position(container)
    open_gripper(env, task)
    pick(env, task, target_pos=[lid_pos[0], lid_pos[1], lid_pos[2] + 0.0185], approach_axis="z")
    place(env, task, target_pos=[jar_pos[0], jar_pos[1], jar_pos[2] + 0.058], approach_axis="z")
