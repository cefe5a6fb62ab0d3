"""Executing ΣΛ plans with a robot (paper, "Executing ΣΛ trajectories with a robot"): the
setup and drawing-plane calibration, timing to the limits, the joint trajectory (Gauss–Newton
on Pinocchio's Panda) and its execution in MuJoCo or export for a real controller."""
