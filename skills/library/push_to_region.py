def push_to_region(env, task, obj="cube", region="zone"):
    """Slide `obj` along the table into `region`, pushing it from behind with the closed hand
    along whichever table axis leads from the object to the region."""
    obj_pos = task.get_object_position(obj)
    region_pos = task.get_object_position(region)
    dx = region_pos[0] - obj_pos[0]
    dy = region_pos[1] - obj_pos[1]
    if abs(dy) > abs(dx):
        sign = 1.0 if dy > 0 else -1.0
        start = [obj_pos[0], obj_pos[1] - 0.06 * sign, obj_pos[2]]
        goal = [obj_pos[0], region_pos[1] - 0.035 * sign, obj_pos[2]]
    else:
        sign = 1.0 if dx > 0 else -1.0
        start = [obj_pos[0] - 0.06 * sign, obj_pos[1], obj_pos[2]]
        goal = [region_pos[0] - 0.035 * sign, obj_pos[1], obj_pos[2]]
    push(env, task, start_pos=start, target_pos=goal, approach_axis="z")
