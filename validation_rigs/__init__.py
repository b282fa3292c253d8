"""Independently written rig models for validating the diagnosis; they import nothing of this
repository (only numpy, pandas, numba), and share no code or functional form with simulators/ or
core/terms.py, core/effects.py. Each exposes `SensorSpec`, `RigRun`, `EFFECT_FORMS`,
`OUT_OF_VOCABULARY` and `simulate_run(scheme, motor_speed_rpm, direction, temp_joint_c, effects,
seed, sensors, periods) -> RigRun`."""
