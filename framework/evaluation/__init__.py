"""Evaluating ΣΛ motions: smoothness and speed metrics, other timings of the same path
(minimum jerk, time-optimal), agreement with human recordings, the quality benchmark."""
