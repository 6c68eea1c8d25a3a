"""Indices of the scalar slots shared between host and kernels.

sim_real (real): time step, gravity, contact buffer and detection scalars;
sim_int (i32): counts and status flags; acc (real): dissipated / external work [J/m].
"""
# sim_real
R_DT = 0        # Δt [s]
R_GX = 1        # gravity x [m/s²]
R_GY = 2        # gravity y [m/s²]
R_BUFFER = 3    # contact buffer b [m]
R_DACC = 4      # accumulated 2 Δt v_max since the last detection [m]
R_RMAX = 5      # largest bounding-circle radius at the last detection [m]
R_CELL = 6      # grid cell size at the last detection [m]
R_VMAX = 7      # largest node speed of the last step [m/s]
R_VLIMIT = 8    # a node speed above this is taken as a sign of instability [m/s]
R_TIME = 9      # simulated time [s] (kept by the kernels; the host uses step_count·Δt)
R_BIG = 10      # a huge number (forces re-detection when stored in R_DACC)
REAL_SLOTS = 12

# sim_int
I_COUPLES = 1       # couples in the list
I_FOUND = 2         # couples found by the last count pass
I_NONFINITE = 3     # 1 + a node whose position or velocity is not finite (0: none)
I_INVERTED = 4      # 1 + a triangle with non-positive area (0: none)
I_OVERFLOW = 5      # couples needed when the buffer was too small (0: no overflow)
I_DETECTIONS = 6    # detections run
I_SPEED = 7         # 1 when a node speed exceeded sim_real[R_VLIMIT]
I_BROKEN = 8        # joints broken so far
INT_SLOTS = 12

# acc
A_FRICTION = 0      # work dissipated by friction slip
A_CDAMPING = 1      # work dissipated by contact damping
A_BOUNDARY = 2      # work done on the system by prescribed velocities
ACC_SLOTS = 4
