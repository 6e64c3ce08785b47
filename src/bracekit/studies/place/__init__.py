"""Where to brace, continuously: the pad's place on a link's surface and the start posture as variables.

surface.py (the capsule surface's parameterisation θ = (s, φ)), snapped.py (the link's collision surface by
the ray rule of ``surface = {fraction, angle}``), kinematics.py (the placed brace's Jacobian and
its derivatives), compliance.py (C_i or c_t and its gradient in (q, θ)), scenario.py (a place as a scenario),
inner.py (the joint optimisation at the start, SciPy SLSQP), outer.py (whole-task evaluation and the
derivative-free refinement), settle.py (MuJoCo's static check of a place), engine.py (both levels on Dask),
report.py (the outputs).
"""
