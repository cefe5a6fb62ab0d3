"""The sigma-lognormal (ΣΛ) model: motor plans, timing parameters and kinematics."""

from inkmotion.sigma_lognormal.batch import GridLayout, PlanBatch
from inkmotion.sigma_lognormal.kinematics import (
    Kinematics,
    batch_kinematics,
    evaluate_kinematics,
    uniform_times,
)
from inkmotion.sigma_lognormal.plan import Drawing, MotorPlan

__all__ = ["Drawing", "GridLayout", "Kinematics", "MotorPlan", "PlanBatch", "batch_kinematics",
           "evaluate_kinematics", "uniform_times"]
