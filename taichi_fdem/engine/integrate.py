"""Explicit central-difference integration of the nodes (FDEM_SPEC §6.1), with prescribed
velocities and their reactions (§12.3), the local (quasi-static) damping, the instability checks
and the re-detection trigger D_acc (§4.1).

Local non-viscous damping (Cundall 1987; the "local damping" of Itasca's PFC/UDEC/3DEC): with
the quasi-static option, each free component d of a node receives the extra force
``F_d = −α |F_d^unbal| sign(v_d)``, where F^unbal = f + m g is the unbalanced force and v the
velocity of the last half step.  It damps every mode alike (its strength is a fraction α of the
force that drives the motion, not a viscosity tied to a frequency) and vanishes for steady
motion (no unbalanced force), so a body at equilibrium or sliding steadily is not resisted; it
is meant for reaching static equilibrium, not for dynamics.  Its work is booked in
step_real[WORK_LOCAL].
"""
import taichi as ti

from .groups import DACC, NONFINITE, QS_ALPHA, SWITCH_BC, SWITCH_BC_WORK, TIME, VMAX, WORK_BOUNDARY, WORK_LOCAL
from .tiutil import vec2

CHUNK = 256   # nodes per chunk in reductions (one atomic per chunk, not per node)


@ti.func
def _sign(x):
    s = 0.0
    if x > 0.0:
        s = 1.0
    elif x < 0.0:
        s = -1.0
    return s


@ti.func
def integrate_nodes(nodes: ti.template(), step: ti.template(), local_damping: ti.template()):
    """v += Δt (f/m + g); prescribed velocities; x += Δt v; f = 0; v_max, D_acc, time.

    With ``local_damping`` (compile time), the local damping of the module docstring with
    α = step_real[QS_ALPHA].  With prescribed velocities, nodes.node_react[i] receives the force
    the constraint exerted, R = (1 − free)(m (v_b − v)/Δt − f − m g) (§12.3).
    A node speed above step.step_vlimit is read as instability (see :func:`taichi_fdem.engine.step.is_unstable`).
    """
    N = nodes.node_x.shape[0]
    dt = step.step_dt[None]
    g = step.step_gravity[None]
    bc = step.step_switches[None] & SWITCH_BC
    bc_work = step.step_switches[None] & SWITCH_BC_WORK
    alpha = 0.0
    if ti.static(local_damping):
        alpha = step.step_real[QS_ALPHA]
    for _ in range(1):
        step.step_real[VMAX] = 0.0
    for chunk in range((N + CHUNK - 1) // CHUNK):
        vmax2 = 0.0
        bad = 0
        work = 0.0
        local = 0.0
        for i in range(chunk * CHUNK, ti.min(N, chunk * CHUNK + CHUNK)):
            m = nodes.node_mass[i]
            v = nodes.node_v[i] + dt * (nodes.node_f[i] / m + g)
            if ti.static(local_damping):
                v0 = nodes.node_v[i]
                F = nodes.node_f[i] + m * g
                fd = -alpha * vec2(ti.abs(F[0]) * _sign(v0[0]), ti.abs(F[1]) * _sign(v0[1]))
                if bc != 0:
                    fd *= nodes.node_free[i]          # prescribed components are not damped
                v += (dt / m) * fd
                local -= dt * fd.dot(v)
            if bc != 0:
                free = nodes.node_free[i]
                vb = nodes.node_vbc[i]
                nodes.node_react[i] = (1.0 - free) * (m * (vb - nodes.node_v[i]) / dt - nodes.node_f[i] - m * g)
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
        if ti.static(local_damping):
            ti.atomic_add(step.step_real[WORK_LOCAL], local)
    for _ in range(1):
        # re-detection trigger D_acc += 2 Δt v_max (§4.1)
        step.step_real[DACC] += 2.0 * dt * step.step_real[VMAX]
        step.step_real[TIME] += dt
