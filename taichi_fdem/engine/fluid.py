"""Fluid flow in the fracture network and its pressure on the fracture faces (hydro-mechanical
coupling; docs/theory/fluid.md).

The network.  Its edges are the candidate edges fixed at build (:mod:`taichi_fdem.sim.fluid`):
the edges of pre-existing cracks, which conduct from the start, and the joints of fracturing
bodies, which conduct once broken (or, with ``conduct="damaged"``, once softened past their
peak: any stored damage D > 0).  An edge has the two faces of the split mesh, four node copies
(a0, a1) on triangle A and (b1, b0) on B, in the joints' order (j0, j1, j2, j3) = (A's u, A's
v, B's v, B's u), and two fluid nodes u, v: the original (unsplit) mesh vertices at its ends, so
that the edges meeting at a vertex share one fluid node.

Per step, at the positions x_n (before the integration):

1. aperture: the mean normal opening of the two faces at the edge's ends, w = ½((x_b0 − x_a0)·n
   + (x_b1 − x_a1)·n), n the unit normal of the mid-line pointing from A to B, clamped to
   [a_min, a_max] (0 for an edge that does not conduct); length L; conductance
   C = w³/(12 μ L) [m³/(Pa·s)], the cubic law q = C (p_u − p_v) [m²/s per unit thickness];
2. node volumes V_i = Σ L w / 2 over the node's conducting edges [m²]; the fluid content m_i
   [m²] is the volume the node's fluid takes at the reference density (its mass / ρ), so the
   pressure of the linearised compressible fluid, dp = K dV/V, is p_i = K (m_i/V_i − 1),
   at least 0 (an edge not filled is at zero pressure), 0 where V_i = 0;
3. pressure sources set m_i = V_i (1 + p_s/K) on their conducting nodes, booking what they add
   or take as their volume;
4. the pressure acts on both faces of every conducting edge as a follower load: the consistent
   nodal forces of a linear pressure along the current mid-line, f_a0 = −n L (2 p_u + p_v)/6,
   f_a1 = −n L (p_u + 2 p_v)/6 on A, their opposites on B (the pair adds no net force);
5. flow: explicit Euler over ``nsub`` substeps, nsub = ⌈Δt max_i (K Σ C_i / V_i) / FLOW_CFL⌉
   (forward Euler of dp_i/dt = (K/V_i) Σ C (p_j − p_i) is stable for Δt_sub ≤ V_i/(K Σ C_i)
   by Gershgorin's bound); each substep adds the rate sources (Q A(t) Δt_sub shared equally
   among the source's conducting nodes), moves q Δt_sub along each edge and recomputes the
   pressures (step 2 on the step's volumes), then applies the pressure sources (step 3).

The fluid's work on the solid is booked as the loads' is (engine.loads): half with the
velocities before the integration, half with those after (:func:`book_fluid_work`), in
``fluid_real[F_WORK]``.

Content moves only along edges (what leaves one node enters the other, from the one stored
flux) and through the sources, which book it: the stored volume changes by the sum of the
sources' volumes, to round-off (tests/test_fluid.py).  A new edge adds volume to nodes that
hold fluid already, so their pressure drops and the fluid spreads into it: mass is kept.

Arrays (the fluid group, engine.groups.FLUID_MEMBERS):

==============  =======================================================================
fluid_edge      (E,) i32 vec8: a0, a1, b1, b0 (node copies), u, v (fluid nodes), the joint
                (−1: a crack edge), 0
fluid_edge_val  (E,) real vec8: w [m], L [m], C [m³/(Pa·s)], q [m²/s] (u → v), f_a0 (2),
                f_a1 (2) [N/m]
fluid_node_val  (F,) real vec4: m [m²], V [m²], p [Pa], K Σ C / V [1/s]
fluid_index     i32: the header (:data:`H_NF` ...), then the fluid nodes' edge lists (CSR;
                entry e at an edge's u end, −1 − e at its v end), the solid nodes that
                receive pressure forces and their slot lists (4e + k, k: a0, a1, b1, b0),
                the sources (kind, curve start, curve count, first node) and their nodes
fluid_real      real: the parameters and counters (:data:`F_K` ...), then per source
                SRC_STRIDE values (the value, the rate now, the cumulative volume, this
                step's volume)
==============  =======================================================================

Precision: p = K (m/V − 1) resolves pressures to about K × the machine epsilon, ~0.5 µPa in f64
but ~260 Pa in f32 with water's K = 2.2e9 Pa (enough for fracturing pressures of MPa).

In the parallel strategy the geometry, the forces and their gather are parallel loops; the
flow substeps are one serial task (the network is small next to the mesh).  Results do not
depend on the strategy beyond the order of the nodal force sums.
"""
import taichi as ti

from .groups import DT
from .groups import NONFINITE, TIME
from .loads import curve_value
from .tiutil import vec2

# fluid_real: parameters (set at build) and counters
F_K = 0             # bulk modulus K [Pa]
F_MU = 1            # viscosity μ [Pa·s]
F_AMIN = 2          # aperture_min [m]
F_AMAX = 3          # aperture_max [m] (a huge value without one)
F_DAMAGED = 4       # 1: joints damaged past their peak conduct; 0: only broken ones
F_WORK = 5          # work done by the fluid on the solid [J/m]
F_RATE = 6          # max over nodes of K Σ C / V at the last step [1/s]
F_SUBSTEPS = 7      # flow substeps of the last step
F_BAD = 8           # 0, or why the fluid stopped the run (BAD_NONFINITE, BAD_SUBSTEPS)
F_HEAD = 10         # first source entry
SRC_STRIDE = 4      # per source: value (rate [m²/s] or pressure [Pa]), rate now [m²/s], volume [m²], step volume
# fluid_index header
H_NF = 0            # fluid nodes
H_NG = 1            # solid nodes receiving pressure forces
H_NS = 2            # sources
H_NE_START = 3      # offset of the fluid nodes' edge-list starts (F + 1 absolute offsets)
H_G_NODE = 4        # offset of the receiving solid nodes (G)
H_G_START = 5       # offset of their slot-list starts (G + 1 absolute offsets)
H_SRC = 6           # offset of the source rows (4 per source, then one more first-node entry)
HEADER = 8
SRC_RATE = 1
SRC_PRESSURE = 2
BAD_NONFINITE = 1
BAD_SUBSTEPS = 2

#: Δt_sub · max(K Σ C / V) of the flow substeps: half the explicit limit (the update is then
#: monotone as well as stable)
FLOW_CFL = 0.5
#: above this many substeps per step the run stops (BAD_SUBSTEPS): a smaller Δt or a larger
#: aperture_min / viscosity is needed
SUBSTEPS_MAX = 1 << 16


@ti.func
def fluid_pressure(m, V, K):
    """p = K (m/V − 1) [Pa], at least 0; 0 where V = 0 (module docstring, step 2)."""
    p = 0.0
    if V > 0.0:
        p = ti.max(0.0, K * (m / V - 1.0))
    return p


@ti.func
def edge_frame(en, nodes: ti.template()):
    """(n, L, opening at u, opening at v) of an edge from the current positions: n the unit
    normal of the faces' mid-line pointing from A to B, L its length [m]."""
    xa0 = nodes.node_x[en[0]]
    xa1 = nodes.node_x[en[1]]
    xb1 = nodes.node_x[en[2]]
    xb0 = nodes.node_x[en[3]]
    d = 0.5 * (xa1 + xb1 - xa0 - xb0)
    L = d.norm()
    n = vec2(0.0, 0.0)
    if L > 0.0:
        n = vec2(d[1], -d[0]) / L        # A lies on the left of u → v
    return n, L, (xb0 - xa0).dot(n), (xb1 - xa1).dot(n)


@ti.func
def edge_conducts(en, fl: ti.template(), joints: ti.template()):
    """1 if the edge conducts: a crack edge always, a joint once broken (or damaged past its
    peak with ``fluid_real[F_DAMAGED]``)."""
    c = 1
    j = en[6]
    if j >= 0:
        c = 0
        if joints.joint_state[j] != 0:
            c = 1
        elif fl.fluid_real[F_DAMAGED] > 0.0:
            dm = joints.joint_dmax[j]
            if dm[0] > 0.0 or dm[1] > 0.0 or dm[2] > 0.0:
                c = 1
    return c


@ti.func
def update_edges(nodes: ti.template(), joints: ti.template(), fl: ti.template()):
    """Step 1: aperture, length and conductance of every edge; the pressure at a joint that
    broke in this step, the mean of its two fluid nodes' (from the last step), into
    joint_break[j][3] (the crack event's ``pressure``)."""
    mu = fl.fluid_real[F_MU]
    amin = fl.fluid_real[F_AMIN]
    amax = fl.fluid_real[F_AMAX]
    for e in range(fl.fluid_edge.shape[0]):
        en = fl.fluid_edge[e]
        n, L, ou, ov = edge_frame(en, nodes)
        ev = fl.fluid_edge_val[e]
        w = 0.0
        C = 0.0
        if edge_conducts(en, fl, joints) != 0 and L > 0.0:
            w = ti.min(ti.max(0.5 * (ou + ov), amin), amax)
            C = w * w * w / (12.0 * mu * L)
        ev[0] = w
        ev[1] = L
        ev[2] = C
        fl.fluid_edge_val[e] = ev
        j = en[6]
        if j >= 0:
            if joints.joint_state[j] != 0 and joints.joint_break[j][3] < 0.0:
                # the joint broke in this step: the pressure there, the mean of its ends' (last step's)
                jb = joints.joint_break[j]
                jb[3] = 0.5 * (fl.fluid_node_val[en[4]][2] + fl.fluid_node_val[en[5]][2])
                joints.joint_break[j] = jb


@ti.func
def node_edge(code):
    """(edge, sign) of an entry of a fluid node's edge list: +1 at the edge's u end, −1 at v."""
    e = code
    s = 1.0
    if code < 0:
        e = -1 - code
        s = -1.0
    return e, s


@ti.func
def update_volumes(fl: ti.template()):
    """Step 2: every fluid node's volume, pressure and rate K Σ C / V; the largest rate in
    fluid_real[F_RATE] (reset by the caller)."""
    K = fl.fluid_real[F_K]
    NF = fl.fluid_index[H_NF]
    s0 = fl.fluid_index[H_NE_START]
    for i in range(NF):
        V = 0.0
        S = 0.0
        for a in range(fl.fluid_index[s0 + i], fl.fluid_index[s0 + i + 1]):
            e, _ = node_edge(fl.fluid_index[a])
            ev = fl.fluid_edge_val[e]
            V += 0.5 * ev[1] * ev[0]
            S += ev[2]
        nv = fl.fluid_node_val[i]
        nv[1] = V
        nv[2] = fluid_pressure(nv[0], V, K)
        r = 0.0
        if V > 0.0:
            r = K * S / V
        nv[3] = r
        fl.fluid_node_val[i] = nv
        ti.atomic_max(fl.fluid_real[F_RATE], r)


@ti.func
def source_row(s, fl: ti.template()):
    """(kind, curve start, curve count, first node, end node) of source s."""
    r = fl.fluid_index[H_SRC] + 4 * s
    return fl.fluid_index[r], fl.fluid_index[r + 1], fl.fluid_index[r + 2], fl.fluid_index[r + 3], \
        fl.fluid_index[r + 7]


@ti.func
def book_source(s, vol, fl: ti.template()):
    """Add vol [m²] to source s's cumulative and step volumes."""
    k = F_HEAD + SRC_STRIDE * s
    fl.fluid_real[k + 2] += vol
    fl.fluid_real[k + 3] += vol


@ti.func
def apply_pressure_sources(t, nodes: ti.template(), fl: ti.template()):
    """Step 3: the pressure sources set the content of their conducting nodes to V (1 + p_s/K)
    (p_s = A(t) × the value, at least 0) and book the change."""
    K = fl.fluid_real[F_K]
    for s in range(fl.fluid_index[H_NS]):
        kind, c0, cn, lo, hi = source_row(s, fl)
        if kind == SRC_PRESSURE:
            ps = ti.max(0.0, curve_value(nodes.curve_points, c0, cn, t) * fl.fluid_real[F_HEAD + SRC_STRIDE * s])
            vol = 0.0
            for a in range(lo, hi):
                i = fl.fluid_index[a]
                nv = fl.fluid_node_val[i]
                if nv[1] > 0.0:
                    target = nv[1] * (1.0 + ps / K)
                    vol += target - nv[0]
                    nv[0] = target
                    nv[2] = ps
                    fl.fluid_node_val[i] = nv
            book_source(s, vol, fl)


@ti.func
def apply_rate_sources(t, dts, nodes: ti.template(), fl: ti.template()):
    """The rate sources' volume over a substep dts, shared equally among each source's
    conducting nodes (none conducting: nothing enters)."""
    for s in range(fl.fluid_index[H_NS]):
        kind, c0, cn, lo, hi = source_row(s, fl)
        if kind == SRC_RATE:
            q = curve_value(nodes.curve_points, c0, cn, t) * fl.fluid_real[F_HEAD + SRC_STRIDE * s]
            count = 0
            for a in range(lo, hi):
                if fl.fluid_node_val[fl.fluid_index[a]][1] > 0.0:
                    count += 1
            if count > 0:
                share = q * dts / count
                for a in range(lo, hi):
                    i = fl.fluid_index[a]
                    nv = fl.fluid_node_val[i]
                    if nv[1] > 0.0:
                        nv[0] += share
                        fl.fluid_node_val[i] = nv
                book_source(s, q * dts, fl)


@ti.func
def pressure_forces(nodes: ti.template(), step: ti.template(), fl: ti.template()):
    """Step 4: each conducting edge's nodal forces from the pressures at its ends, kept in
    fluid_edge_val; the first half of their work (module docstring)."""
    dt = step.step_real[DT]
    for e in range(fl.fluid_edge.shape[0]):
        en = fl.fluid_edge[e]
        ev = fl.fluid_edge_val[e]
        f0 = vec2(0.0, 0.0)
        f1 = vec2(0.0, 0.0)
        if ev[0] > 0.0:
            n, L, _, _ = edge_frame(en, nodes)
            pu = fl.fluid_node_val[en[4]][2]
            pv = fl.fluid_node_val[en[5]][2]
            f0 = -(L * (2.0 * pu + pv) / 6.0) * n
            f1 = -(L * (pu + 2.0 * pv) / 6.0) * n
            w = f0.dot(nodes.node_v[en[0]] - nodes.node_v[en[3]]) + f1.dot(nodes.node_v[en[1]] - nodes.node_v[en[2]])
            ti.atomic_add(fl.fluid_real[F_WORK], 0.5 * dt * w)
        ev[4] = f0[0]
        ev[5] = f0[1]
        ev[6] = f1[0]
        ev[7] = f1[1]
        fl.fluid_edge_val[e] = ev


@ti.func
def gather_pressure_forces(nodes: ti.template(), fl: ti.template()):
    """Add the edges' pressure forces to node_f: each receiving node sums its slots in their
    sorted order (no atomics, the same sum in every strategy)."""
    g0 = fl.fluid_index[H_G_NODE]
    s0 = fl.fluid_index[H_G_START]
    for g in range(fl.fluid_index[H_NG]):
        f = vec2(0.0, 0.0)
        for a in range(fl.fluid_index[s0 + g], fl.fluid_index[s0 + g + 1]):
            code = fl.fluid_index[a]
            ev = fl.fluid_edge_val[code // 4]
            k = code % 4
            if k == 0:
                f += vec2(ev[4], ev[5])
            elif k == 1:
                f += vec2(ev[6], ev[7])
            elif k == 2:
                f -= vec2(ev[6], ev[7])
            else:
                f -= vec2(ev[4], ev[5])
        i = fl.fluid_index[g0 + g]
        nodes.node_f[i] = nodes.node_f[i] + f


@ti.func
def flow_substep(t, dts, nodes: ti.template(), fl: ti.template()):
    """Step 5, one substep of dts [s]: rate sources, fluxes, contents and pressures, pressure
    sources.  Returns 1 if a content or pressure is not finite."""
    K = fl.fluid_real[F_K]
    for e in range(fl.fluid_edge.shape[0]):
        en = fl.fluid_edge[e]
        ev = fl.fluid_edge_val[e]
        ev[3] = ev[2] * (fl.fluid_node_val[en[4]][2] - fl.fluid_node_val[en[5]][2])
        fl.fluid_edge_val[e] = ev
    apply_rate_sources(t, dts, nodes, fl)
    bad = 0
    s0 = fl.fluid_index[H_NE_START]
    for i in range(fl.fluid_index[H_NF]):
        dm = 0.0
        for a in range(fl.fluid_index[s0 + i], fl.fluid_index[s0 + i + 1]):
            e, sg = node_edge(fl.fluid_index[a])
            dm -= sg * fl.fluid_edge_val[e][3]
        nv = fl.fluid_node_val[i]
        nv[0] += dts * dm
        nv[2] = fluid_pressure(nv[0], nv[1], K)
        fl.fluid_node_val[i] = nv
        if not (ti.abs(nv[0]) < 1e300 and nv[2] < 1e300):
            bad = 1
    apply_pressure_sources(t + dts, nodes, fl)
    return bad


@ti.func
def fluid_flow(nodes: ti.template(), step: ti.template(), fl: ti.template()):
    """Step 5: the substeps of the flow over Δt, in one serial task; the sources' rates of the
    step; a non-finite fluid or too many substeps stop the run (fluid_real[F_BAD], flagged as
    non-finite in step_int[NONFINITE])."""
    ti.loop_config(serialize=True)
    for _ in range(1):
        dt = step.step_real[DT]
        t = step.step_real[TIME]
        need = dt * fl.fluid_real[F_RATE] / FLOW_CFL
        bad = 0
        if not (need <= SUBSTEPS_MAX):
            bad = BAD_SUBSTEPS
        else:
            nsub = ti.max(1, ti.cast(ti.ceil(need), ti.i32))
            fl.fluid_real[F_SUBSTEPS] = nsub
            dts = dt / nsub
            for k in range(nsub):
                if flow_substep(t + k * dts, dts, nodes, fl) != 0:
                    bad = BAD_NONFINITE
                    break
        for s in range(fl.fluid_index[H_NS]):
            r = F_HEAD + SRC_STRIDE * s
            fl.fluid_real[r + 1] = fl.fluid_real[r + 3] / dt
            fl.fluid_real[r + 3] = 0.0
        if bad != 0:
            fl.fluid_real[F_BAD] = bad
            step.step_int[NONFINITE] = ti.max(step.step_int[NONFINITE], 1)


@ti.func
def fluid_step(nodes: ti.template(), joints: ti.template(), step: ti.template(), fl: ti.template()):
    """The fluid's phase of a step, before the integration: steps 1–5 of the module docstring
    (the pressure forces added to node_f)."""
    update_edges(nodes, joints, fl)
    ti.loop_config(serialize=True)
    for _ in range(1):
        fl.fluid_real[F_RATE] = 0.0
    update_volumes(fl)
    ti.loop_config(serialize=True)
    for _ in range(1):
        apply_pressure_sources(step.step_real[TIME], nodes, fl)
    pressure_forces(nodes, step, fl)
    gather_pressure_forces(nodes, fl)
    fluid_flow(nodes, step, fl)


@ti.func
def book_fluid_work(nodes: ti.template(), step: ti.template(), fl: ti.template()):
    """Second half of the fluid's work on the solid over the step, with the new velocities."""
    dt = step.step_real[DT]
    for e in range(fl.fluid_edge.shape[0]):
        ev = fl.fluid_edge_val[e]
        if ev[0] > 0.0:
            en = fl.fluid_edge[e]
            w = vec2(ev[4], ev[5]).dot(nodes.node_v[en[0]] - nodes.node_v[en[3]]) \
                + vec2(ev[6], ev[7]).dot(nodes.node_v[en[1]] - nodes.node_v[en[2]])
            ti.atomic_add(fl.fluid_real[F_WORK], 0.5 * dt * w)
