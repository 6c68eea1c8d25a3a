"""Applied loads, absorbing boundaries and load curves (docs/theory/loads.md §12.1, §12.2, §12.5).

One table in the nodes group holds every load of a scene, one row per entry:

==========  ================================  =================================================
kind        load_nodes (kind, i, j, c0, cn)   load_vals
==========  ================================  =================================================
PRESSURE    boundary edge i→j (CCW)           (p [Pa], 0, 0, 0); f_i = f_j = −A p L n̂ / 2, on
                                              the current edge (a follower load)
TRACTION    boundary edge i→j                 (t_x L0/2, t_y L0/2, 0, 0) [N/m]: f_i = f_j = A ·
                                              that (dead load)
FORCE       node i, j = −1                    (F_x, F_y, 0, 0) [N/m]: f_i = A F
ABSORB      boundary edge i→j                 (ρ c_p, ρ c_s, 0, 0) [Pa·s/m]: Lysmer–Kuhlemeyer
                                              dashpots, f_i = −(L/2)(ρc_p (v_i·n̂) n̂ + ρc_s
                                              (v_i·ŝ) ŝ)
VELOCITY    node i, component j (0 x, 1 y)    (v [m/s], 0, 0, 0): node_vbc[i][j] = A v
==========  ================================  =================================================

A = the amplitude of curve (c0, cn): the cn points curve_points[c0 : c0 + cn] (t, A), linear
between them and constant past the ends; cn = 0 means A = 1.  Forces use A(t_n), prescribed
velocities A(t_n + Δt/2) (they are the velocities of the half step).

Work: the forces of each entry are kept in load_force; their work over the step is booked
half with the old velocities (:func:`apply_loads`) and half with the new ones
(:func:`book_load_work`), like the joints' work: in step_real[WORK_LOAD] for loads, and as
dissipation in step_real[WORK_ABSORB] for the dashpots.
"""
import taichi as ti

from .groups import DT
from .groups import TIME, WORK_ABSORB, WORK_LOAD
from .tiutil import vec2

LOAD_PRESSURE = 1
LOAD_TRACTION = 2
LOAD_FORCE = 3
LOAD_ABSORB = 4
LOAD_VELOCITY = 5


@ti.func
def curve_value(curve_points: ti.template(), c0, cn, t):
    """Amplitude at time t of the piecewise-linear curve curve_points[c0 : c0 + cn] (1 if cn = 0)."""
    a = 1.0
    if cn > 0:
        first = curve_points[c0]
        last = curve_points[c0 + cn - 1]
        if t <= first[0]:
            a = first[1]
        elif t >= last[0]:
            a = last[1]
        else:
            for k in range(c0, c0 + cn - 1):
                p = curve_points[k]
                q = curve_points[k + 1]
                if t < q[0]:
                    a = p[1] + (q[1] - p[1]) * (t - p[0]) / (q[0] - p[0])
                    break
    return a


@ti.func
def apply_load(k, t, dt, nodes: ti.template(), step: ti.template()):
    """Load entry k at time t [s]: add its forces at t to nodes.node_f, or set its curve-driven
    prescribed velocity for t + Δt/2; book the first half of its work."""
    ld = nodes.load_nodes[k]
    kind = ld[0]
    i = ld[1]
    j = ld[2]
    val = nodes.load_vals[k]
    if kind == LOAD_VELOCITY:
        a = curve_value(nodes.curve_points, ld[3], ld[4], t + 0.5 * dt)
        if j == 0:
            nodes.node_vbc[i][0] = a * val[0]
        else:
            nodes.node_vbc[i][1] = a * val[0]
    else:
        a = curve_value(nodes.curve_points, ld[3], ld[4], t)
        fi = vec2(0.0, 0.0)
        fj = vec2(0.0, 0.0)
        vi = nodes.node_v[i]
        vj = vec2(0.0, 0.0)
        if kind == LOAD_FORCE:
            fi = a * vec2(val[0], val[1])
        else:
            vj = nodes.node_v[j]
            if kind == LOAD_TRACTION:
                fi = a * vec2(val[0], val[1])
                fj = fi
            else:
                d = nodes.node_x[j] - nodes.node_x[i]
                nL = vec2(d[1], -d[0])              # outward normal × L (the body on the left)
                if kind == LOAD_PRESSURE:
                    fi = -0.5 * a * val[0] * nL
                    fj = fi
                elif kind == LOAD_ABSORB:
                    L = d.norm()
                    nh = nL / L
                    sh = d / L
                    fi = -0.5 * L * (val[0] * vi.dot(nh) * nh + val[1] * vi.dot(sh) * sh)
                    fj = -0.5 * L * (val[0] * vj.dot(nh) * nh + val[1] * vj.dot(sh) * sh)
            ti.atomic_add(nodes.node_f[j], fj)
        ti.atomic_add(nodes.node_f[i], fi)
        nodes.load_force[k] = ti.Vector([fi[0], fi[1], fj[0], fj[1]], dt=float)
        w = 0.5 * dt * (fi.dot(vi) + fj.dot(vj))
        if kind == LOAD_ABSORB:
            ti.atomic_sub(step.step_real[WORK_ABSORB], w)
        else:
            ti.atomic_add(step.step_real[WORK_LOAD], w)


@ti.func
def apply_loads(nodes: ti.template(), step: ti.template()):
    """Add the forces of every load entry at t_n to nodes.node_f; set curve-driven prescribed
    velocities for t_n + Δt/2; book the first half of the loads' work (:func:`apply_load`)."""
    t = step.step_real[TIME]
    dt = step.step_real[DT]
    ti.loop_config(serialize=True)   # few entries: one thread, cheaper than a parallel loop's launch
    for k in range(nodes.load_nodes.shape[0]):
        apply_load(k, t, dt, nodes, step)


@ti.func
def book_load(k, dt, nodes: ti.template(), step: ti.template()):
    """Second half of load entry k's work over the step, with the new velocities."""
    ld = nodes.load_nodes[k]
    kind = ld[0]
    if kind != LOAD_VELOCITY:
        f = nodes.load_force[k]
        w = f[0] * nodes.node_v[ld[1]][0] + f[1] * nodes.node_v[ld[1]][1]
        if kind != LOAD_FORCE:
            w += f[2] * nodes.node_v[ld[2]][0] + f[3] * nodes.node_v[ld[2]][1]
        w *= 0.5 * dt
        if kind == LOAD_ABSORB:
            ti.atomic_sub(step.step_real[WORK_ABSORB], w)
        else:
            ti.atomic_add(step.step_real[WORK_LOAD], w)


@ti.func
def book_load_work(nodes: ti.template(), step: ti.template()):
    """Second half of the loads' work over the step, with the new velocities (see the module)."""
    dt = step.step_real[DT]
    ti.loop_config(serialize=True)   # few entries: one thread, cheaper than a parallel loop's launch
    for k in range(nodes.load_nodes.shape[0]):
        book_load(k, dt, nodes, step)


@ti.kernel
def eval_curve(curve_points: ti.types.ndarray(), c0: ti.i32, cn: ti.i32, times: ti.types.ndarray(),
               out: ti.types.ndarray()):
    """out[k] = amplitude of curve (c0, cn) at times[k], with the kernels' own evaluation."""
    for k in range(times.shape[0]):
        out[k] = curve_value(curve_points, c0, cn, times[k])
