"""Explicit central-difference integration of the nodes (FDEM_SPEC §6.1), with prescribed
velocities, the instability checks and the re-detection trigger D_acc (§4.1)."""
import taichi as ti

from .groups import DACC, NONFINITE, SWITCH_BC, SWITCH_BC_WORK, TIME, VMAX, WORK_BOUNDARY
from .tiutil import vec2

CHUNK = 256   # nodes per chunk in reductions (one atomic per chunk, not per node)


@ti.func
def integrate_nodes(nodes: ti.template(), step: ti.template()):
    """v += Δt (f/m + g); prescribed velocities; x += Δt v; f = 0; v_max, D_acc, time.

    A node speed above step.step_vlimit is read as instability (see :func:`taichi_fdem.engine.step.is_unstable`).
    """
    N = nodes.node_x.shape[0]
    dt = step.step_dt[None]
    g = step.step_gravity[None]
    bc = step.step_switches[None] & SWITCH_BC
    bc_work = step.step_switches[None] & SWITCH_BC_WORK
    for _ in range(1):
        step.step_real[VMAX] = 0.0
    for chunk in range((N + CHUNK - 1) // CHUNK):
        vmax2 = 0.0
        bad = 0
        work = 0.0
        for i in range(chunk * CHUNK, ti.min(N, chunk * CHUNK + CHUNK)):
            m = nodes.node_mass[i]
            v = nodes.node_v[i] + dt * (nodes.node_f[i] / m + g)
            if bc != 0:
                free = nodes.node_free[i]
                vb = nodes.node_vbc[i]
                if bc_work != 0:
                    # work of the constraint force R = m (v_b − v_free)/Δt over x_{n+1} − x_n = Δt v_b
                    work += ((1.0 - free) * m * (vb - v)).dot(vb)
                v = free * v + (1.0 - free) * vb
            x = nodes.node_x[i] + dt * v
            nodes.node_v[i] = v
            nodes.node_x[i] = x
            nodes.node_f[i] = vec2(0.0, 0.0)
            s = v.norm_sqr()
            if not (s < 1e200) or not (ti.abs(x[0]) < 1e200 and ti.abs(x[1]) < 1e200):
                bad = i + 1
            vmax2 = ti.max(vmax2, s)
        ti.atomic_max(step.step_real[VMAX], ti.sqrt(vmax2))
        if bad > 0:
            ti.atomic_max(step.step_int[NONFINITE], bad)
        if bc_work != 0:
            ti.atomic_add(step.step_real[WORK_BOUNDARY], work)
    for _ in range(1):
        # re-detection trigger D_acc += 2 Δt v_max (§4.1)
        step.step_real[DACC] += 2.0 * dt * step.step_real[VMAX]
        step.step_real[TIME] += dt
