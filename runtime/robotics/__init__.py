"""The robotics core: kinematics and IK, the velocity QP and its constraints, trajectory
generation, the collision world and planning. Pure Python on numpy, pinocchio, ruckig,
qpsolvers, FCL and OMPL: it imports no service and no web framework."""
