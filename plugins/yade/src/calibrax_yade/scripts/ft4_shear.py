# calibrax-yade: the FT4 shear test, run inside YADE as
#     yade -n -j THREADS -x ft4_shear.py PARAMS.json
# This file is fixed (shipped with the package, never generated). Every number comes from the
# JSON parameter file written and validated by calibrax_yade.simulator; the results go to
# result.json (or failure.json) and the log to ft4_shear.log, next to the parameter file.
#
# Conventions shared with numba_dem (see its README): σ = F_head / (π R_head²) with F_head the
# vertical force of the particles on the head (disc + blades); τ = 3T/(2π R_head³) with T the
# torque the bed opposes to the rotation (both converted by the plugin from the raw force and
# torque written here); bed height = height of the head's lower face (the disc); rotation counted
# from 0 at each step's start; bulk density = mass below the head's face / (π R_vessel² z_h).
import json
import math
import os
import sys
import time

from yade import utils

PARAMS_PATH = os.path.abspath(sys.argv[1])
WD = os.path.dirname(PARAMS_PATH)
with open(PARAMS_PATH) as fh:
    P = json.load(fh)

LOG = open(os.path.join(WD, "ft4_shear.log"), "w")
T_WALL0 = time.time()


def log(msg):
    LOG.write(msg + "\n")
    LOG.flush()


def write_json(name, data):
    tmp = os.path.join(WD, name + ".tmp")
    with open(tmp, "w") as fh:
        json.dump(data, fh)
    os.replace(tmp, os.path.join(WD, name))


def fail(kind, reason):
    log("FAILED (%s): %s" % (kind, reason))
    write_json("failure.json", {"kind": kind, "reason": reason})
    LOG.close()
    os._exit(3)


# ------------------------------------------------------------------ parameters
DT = P["dt"]
G = P["gravity"]
RHO = P["density"]
RC = P["vessel_radius"]
HEAD_R = P["head_radius"]
BLADE_H = P["blade_height"]
R0 = P["radius"]
AREA = math.pi * HEAD_R ** 2
NSUB = int(P["servo_substeps"])
RATE = P["rotation_rate"]
MAX_SPEED = P["max_speed"]


def atan(mu):
    return math.atan(mu)


# ------------------------------------------------------------------ materials
mat_p = O.materials.append(FrictMat(young=P["young"], poisson=P["poisson"], density=RHO,
                                    frictionAngle=atan(P["pour_friction"]), label="particles"))
mat_w = O.materials.append(FrictMat(young=P["facet_young"], poisson=P["facet_poisson"], density=RHO,
                                    frictionAngle=atan(P["wall_friction"]), label="wall"))
mat_b = O.materials.append(FrictMat(young=P["facet_young"], poisson=P["facet_poisson"], density=RHO,
                                    frictionAngle=atan(P["base_friction"]), label="base"))
mat_h = O.materials.append(FrictMat(young=P["facet_young"], poisson=P["facet_poisson"], density=RHO,
                                    frictionAngle=atan(P["head_friction"]), label="head"))


def friction_matches(mu_p, mu_w, mu_b, mu_h):
    return MatchMaker(matches=((mat_p, mat_p, atan(mu_p)), (mat_p, mat_w, atan(mu_w)),
                               (mat_p, mat_b, atan(mu_b)), (mat_p, mat_h, atan(mu_h))),
                      algo="min")


FRICTION = {mat_p: P["friction"], mat_w: P["wall_friction"], mat_b: P["base_friction"], mat_h: P["head_friction"]}
POUR_MU = P["pour_friction"]
POUR_FRICTION = {mat_p: POUR_MU, mat_w: min(P["wall_friction"], POUR_MU), mat_b: POUR_MU, mat_h: POUR_MU}


# ------------------------------------------------------------------ bodies
# collision masks: spheres meet spheres and facets, facets never meet facets (the collider's
# avoidSelfInteractionMask)
SPHERE_MASK, FACET_MASK, NO_SELF_MASK = 1, 3, 2


def add_facets(flat, material):
    ids = []
    for k in range(0, len(flat), 9):
        v = flat[k:k + 9]
        f = utils.facet([(v[0], v[1], v[2]), (v[3], v[4], v[5]), (v[6], v[7], v[8])], material=material,
                        fixed=True, wire=True, mask=FACET_MASK)
        ids.append(O.bodies.append(f))
    return ids


wall_ids = add_facets(P["vessel_facets"], mat_w)
base_ids = add_facets(P["base_facets"], mat_b) + add_facets(P["rib_facets"], mat_b)
radii = P["radii"]
pos = P["positions"]
vel = P["velocities"]
sphere_ids = []
for i, r in enumerate(radii):
    b = utils.sphere((pos[3 * i], pos[3 * i + 1], pos[3 * i + 2]), r, material=mat_p, mask=SPHERE_MASK)
    b.state.vel = Vector3(vel[3 * i], vel[3 * i + 1], vel[3 * i + 2])
    sphere_ids.append(O.bodies.append(b))
N = len(sphere_ids)
MASSES = [O.bodies[i].state.mass for i in sphere_ids]
BED_MASS = sum(MASSES)
head_ids = []
disc_ref = None  # a facet of the head's disc: its z is the head's height

# ------------------------------------------------------------------ engines
ip2 = Ip2_FrictMat_FrictMat_MindlinPhys(en=MatchMaker(matches=(), algo="val", val=P["restitution"]),
                                        es=MatchMaker(matches=(), algo="val", val=P["shear_restitution"]),
                                        krot=0.0, ktwist=0.0, eta=0.0,
                                        frictAngle=friction_matches(POUR_MU, POUR_FRICTION[mat_w], POUR_MU, POUR_MU))
law = Law2_ScGeom_MindlinPhys_Mindlin(includeMoment=True)
newton = NewtonIntegrator(gravity=(0, 0, -G * P["pour_gravity"]), damping=0.0)
trans = TranslationEngine(translationAxis=(0, 0, 1), velocity=0.0, ids=[])
rot = RotationEngine(rotationAxis=(0, 0, 1), angularVelocity=0.0, rotateAroundZero=True, zeroPoint=(0, 0, 0), ids=[])
head_engine = trans + rot
head_engine.dead = True  # switched on when the head is placed


def clear_wall_rolling():
    """Take the rolling resistance off the lateral wall's contacts (numba_dem and LIGGGHTS give a
    wall without friction none; YADE's Ip2 gives every new contact eta's rolling limit: see
    docs/explanation/yade-contact-law.md). Run every wall_rolling_period steps: a new wall contact
    keeps its rolling stiffness for at most that many steps, then its limit is 0 and its moment 0."""
    for fid in wall_ids:
        for I in O.interactions.withBody(fid):
            ph = I.phys
            if ph is not None and ph.maxBendPl != 0.0:
                ph.maxBendPl = 0.0
                ph.kr = 0.0
                ph.momentBend = Vector3(0, 0, 0)


# the head's kinematic engine is in the loop from the start (with no bodies until the head is
# placed): the engine list is never replaced mid-run
WALL_ROLLING = bool(P["wall_rolling"])
ENGINES = [ForceResetter(),
           InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Facet_Aabb()], avoidSelfInteractionMask=NO_SELF_MASK),
           InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Facet_Sphere_ScGeom()], [ip2], [law]),
           head_engine, newton, PyRunner(iterPeriod=NSUB, command="servo_tick()")]
if not WALL_ROLLING:
    ENGINES.append(PyRunner(iterPeriod=int(P["wall_rolling_period"]), command="clear_wall_rolling()"))
O.engines = ENGINES
O.dt = DT

# ------------------------------------------------------------------ the head's servo
# The head is a rigid body of mass M under the target load F* with a damper acting on v − v_ref
# (v_ref: v low-passed over τ_ref), as numba_dem's servo: M dv/dt = F_p − F* − c (v − v_ref).
S = {"mode": 0, "F": 0.0, "v": 0.0, "vref": 0.0, "vmax": 0.0, "mass": 1.0, "damp": 0.0, "tau": 1.0,
     "omega": 0.0, "phi": 0.0, "accF": 0.0, "accT": 0.0, "accN": 0}


def servo_tick():
    if not head_ids:
        return
    f_up = utils.sumForces(head_ids, (0, 0, 1))
    torque = -utils.sumTorques(head_ids, (0, 0, 1), (0, 0, 0))
    S["accF"] += f_up
    S["accT"] += torque
    S["accN"] += 1
    h = NSUB * DT
    S["phi"] += S["omega"] * h
    if S["mode"] == 1:
        v = S["v"]
        acc = (f_up - S["F"] - S["damp"] * (v - S["vref"])) / S["mass"]
        v += acc * h
        v = max(-S["vmax"], min(S["vmax"], v))
        S["v"] = v
        S["vref"] += (v - S["vref"]) * min(1.0, h / S["tau"])
    trans.velocity = S["v"]
    rot.angularVelocity = S["omega"]


def take_accumulators():
    n = max(S["accN"], 1)
    out = (S["accF"] / n, S["accT"] / n)
    S["accF"] = S["accT"] = 0.0
    S["accN"] = 0
    return out


def servo_gains(stress, bed_height):
    """Mass (kg), damping (N s/m), tau_ref (s) as numba_dem's servo_gains (columns of Hertz
    contacts): the head's mass is servo_mass_fraction of the bed's, critically damped on the
    estimated bed stiffness, v_ref low-passed over servo_tau_periods head-bed periods."""
    f = stress * (2.0 * R0) ** 2
    reff = R0 / 2.0
    delta = (f / (4.0 / 3.0 * P["e_star"] * math.sqrt(reff))) ** (2.0 / 3.0)
    k_c = 2.0 * P["e_star"] * math.sqrt(reff * delta)
    k_bed = k_c * AREA / (2.0 * R0 * bed_height)
    mass = P["servo_mass_fraction"] * BED_MASS
    damp = 2.0 * math.sqrt(k_bed * mass)
    period = 2.0 * math.pi * math.sqrt(mass / k_bed)
    return mass, damp, P["servo_tau_periods"] * period


def head_z():
    return O.bodies[disc_ref].state.pos[2] if disc_ref is not None else float("nan")


# ------------------------------------------------------------------ checks and running
Z_CEIL = [max(pos[2::3]) + 10.0 * R0]


def check(phase):
    vmax = 0.0
    out = 0
    first = None
    for i in sphere_ids:
        st = O.bodies[i].state
        p = st.pos
        v = st.vel
        if not (math.isfinite(p[0]) and math.isfinite(p[1]) and math.isfinite(p[2]) and math.isfinite(v.norm())):
            fail("nan", "NaN in the particle state during %s (t = %.5f s)" % (phase, O.time))
        r = O.bodies[i].shape.radius
        if math.hypot(p[0], p[1]) > RC + r or p[2] < -r or p[2] > Z_CEIL[0]:
            out += 1
            if first is None:
                first = (i, p[0], p[1], p[2], r)
        vmax = max(vmax, v.norm())
    if out:
        fail("unstable", "%d particles escaped the cell during %s (t = %.5f s; e.g. body %d at x=%.5g y=%.5g "
             "z=%.5g m, r=%.3g m)" % ((out, phase, O.time) + first))
    if vmax > MAX_SPEED:
        fail("unstable", "blow-up during %s: a particle reached %.3g m/s (t = %.5f s)" % (phase, vmax, O.time))
    if head_ids and not math.isfinite(head_z()):
        fail("nan", "NaN in the head's height during %s" % phase)
    return vmax


def run_steps(n):
    # O.step() runs one step synchronously; O.run(n, True) costs ~40 ms of polling per call
    step = O.step
    for _ in range(int(n)):
        step()


def run_time(duration, phase, chunk=1.0e-3):
    nsteps = int(round(duration / DT))
    per = max(NSUB, int(round(chunk / DT)))
    while nsteps > 0:
        k = min(per, nsteps)
        run_steps(k)
        nsteps -= k
        check(phase)


def bed_top():
    tops = sorted(O.bodies[i].state.pos[2] + O.bodies[i].shape.radius for i in sphere_ids)
    k = max(1, int(0.05 * len(tops)))
    return sum(tops[-k:]) / k


def bulk():
    zh = head_z()
    m = sum(MASSES[k] for k, i in enumerate(sphere_ids) if O.bodies[i].state.pos[2] < zh)
    return m / (math.pi * RC ** 2 * zh)


def max_speed():
    return max(O.bodies[i].state.vel.norm() for i in sphere_ids)


def switch_friction(table, krot, eta):
    """Friction, rolling stiffness and limit for new contacts (Ip2) and existing ones."""
    ip2.frictAngle = friction_matches(table[mat_p], table[mat_w], table[mat_b], table[mat_h])
    ip2.krot = krot
    ip2.eta = eta
    for I in O.interactions:
        if not I.isReal:
            continue
        b1, b2 = O.bodies[I.id1], O.bodies[I.id2]
        m1, m2 = b1.material.id, b2.material.id
        other = m2 if m1 == mat_p else m1
        I.phys.tangensOfFrictionAngle = table[other] if other != mat_p else table[mat_p]
        rolls = WALL_ROLLING or other != mat_w
        I.phys.kr = krot if rolls else 0.0
        I.phys.maxBendPl = eta * 0.5 * (I.geom.refR1 + I.geom.refR2) if rolls else 0.0


# ------------------------------------------------------------------ phases
WARN = []
INSERTION_GAP = [float("nan")]
STEPS = []
BULK = []
SIGMA_ERR = []


def pour():
    h0 = max(pos[2::3])
    t_fall = math.sqrt(2.0 * max(h0 - P["fill_height"], R0) / (G * P["pour_gravity"]))
    run_time(1.5 * t_fall, "pour")
    t_spent = 1.5 * t_fall
    t_max = 10.0 * t_fall + 0.05
    while t_spent < t_max:
        if max_speed() < P["pour_speed"]:
            break
        run_time(2.0e-3, "pour")
        t_spent += 2.0e-3
    newton.gravity = (0, 0, -G)
    switch_friction(FRICTION, P["krot"], P["eta"])
    run_time(3.0e-3, "settle")
    log("t=%.5f s poured %d particles in %.4f s; bed top %.2f mm (target fill height %.2f mm)"
        % (O.time, N, t_spent, bed_top() * 1e3, P["fill_height"] * 1e3))


def set_servo(stress, vmax):
    S["mode"] = 1
    S["F"] = stress * AREA
    S["vmax"] = vmax


def insert_blades(stress):
    """numba_dem's insert_blades: place the head with its blade tips above the bed, its servo tuned
    for ``stress`` (Pa), and take the turning blades into the bed under insertion_stress_fraction of
    it with the pour's friction (no rolling resistance) until the head's face is down to the poured
    bed's highest particle top, at most insertion_time_limit s; then the material's friction."""
    global disc_ref
    top = bed_top()
    highest = max(O.bodies[i].state.pos[2] + O.bodies[i].shape.radius for i in sphere_ids)
    # blade tips approach_clearance diameters above the bed's surface, and in any case above the
    # highest particle: a blade placed into a sphere would launch it
    z0 = max(top + P["approach_clearance"] * 2.0 * R0, highest + 0.1 * R0) + BLADE_H
    Z_CEIL[0] = z0 + 10.0 * R0
    disc = P["head_disc_facets"]
    blades = P["head_blade_facets"]
    shift = lambda flat: [c + (z0 if k % 3 == 2 else 0.0) for k, c in enumerate(flat)]
    ids = add_facets(shift(disc), mat_h)
    disc_ref = ids[0]
    ids += add_facets(shift(blades), mat_h)
    head_ids.extend(ids)
    head_engine.ids = ids  # the combined engine moves its own ids with each sub-engine's motion
    trans.ids = ids
    rot.ids = ids
    head_engine.dead = False
    mass, damp, tau = servo_gains(stress, top)
    S.update(mass=mass, damp=damp, tau=tau, v=0.0, vref=0.0)
    log("t=%.5f s head placed at %.2f mm (bed top %.2f mm); %d head facets; servo mass %.3g kg, damping %.3g N s/m, "
        "tau_ref %.3g s" % (O.time, z0 * 1e3, top * 1e3, len(ids), mass, damp, tau))
    # the head turns while it descends, so that the blades cut into the bed (as the FT4 does)
    S["omega"] = RATE
    switch_friction(POUR_FRICTION, 0.0, 0.0)
    set_servo(P["insertion_stress_fraction"] * stress, P["approach_speed"])
    t0 = O.time
    goal = highest + P["insertion_tolerance"]
    while head_z() > goal and O.time - t0 < P["insertion_time_limit"]:
        run_time(1.0e-3, "blade insertion")
    switch_friction(FRICTION, P["krot"], P["eta"])
    gap = (head_z() - highest) / R0
    INSERTION_GAP[0] = gap
    if head_z() > goal:
        WARN.append("blade insertion: after %.3g s the head's face was still %.2f particle radii above the poured "
                    "bed's top: the blades are not fully in the bed" % (P["insertion_time_limit"], gap))
    log("t=%.5f s blades inserted in %.4f s: head face at %.2f mm, the poured bed's highest particle reached %.2f mm"
        % (O.time, O.time - t0, head_z() * 1e3, highest * 1e3))


def consolidate(stress):
    """numba_dem's consolidation (docs/explanation/shear-test.md): hold ``stress`` (Pa) while turning,
    at least consolidation_min_time, then until the head has stopped sinking (< 1/200 diameter in
    3 ms) with sigma (last 1 ms) within 5 % of ``stress``; at most consolidation_time_limit."""
    set_servo(stress, P["approach_speed"])
    S["omega"] = RATE
    z_prev = head_z()
    t0 = O.time
    phi0 = S["phi"]
    sigma = float("nan")
    t_min = P["consolidation_min_time"]
    t_max = P["consolidation_time_limit"]
    while True:
        run_time(2.0e-3, "consolidation")
        take_accumulators()
        run_time(1.0e-3, "consolidation")
        f, _ = take_accumulators()
        sigma = f / AREA
        z = head_z()
        moved = abs(z - z_prev)
        z_prev = z
        if O.time - t0 > t_min and moved < 0.005 * 2 * R0 and abs(sigma / stress - 1) < 0.05:
            break
        if O.time - t0 > t_max:
            WARN.append("consolidation: the head was still moving after %.3g s (%.3g x one preshear rotation)"
                        % (t_max, t_max / t_min))
            break
    S["omega"] = 0.0
    log("t=%.5f s consolidated in %.4f s (head turned %.3f rad): head at %.2f mm, sigma = %.0f Pa (target %.0f), "
        "bulk density %.0f kg/m3" % (O.time, O.time - t0, S["phi"] - phi0, head_z() * 1e3, sigma, stress, bulk()))


def preshear_drift(tau, sig, m):
    """calibrax.core.sheartest.preshear_drift (this script runs under YADE's own Python): the relative
    difference of mean tau / mean sigma between the last m samples and the m before them."""
    if len(tau) < 2 * m:
        return float("nan")
    m_last = sum(tau[-m:]) / sum(sig[-m:])
    m_before = sum(tau[-2 * m:-m]) / sum(sig[-2 * m:-m])
    return abs(m_last - m_before) / abs(m_last) if m_last != 0 else float("inf")


def unload_torque(max_rotation=None):
    if max_rotation is None:
        max_rotation = P["unload_max_rotation"]
    chunk = max(NSUB, NSUB * int(round(2.0e-4 / DT / NSUB)))
    phi0 = S["phi"]
    S["omega"] = -RATE
    take_accumulators()
    while phi0 - S["phi"] < max_rotation:
        run_steps(chunk)
        _, torque = take_accumulators()
        if torque <= 0.0:
            break
    S["omega"] = 0.0
    check("torque unload")
    return phi0 - S["phi"]


def settle(stress):
    back = unload_torque()
    set_servo(stress, P["shear_speed_limit"])
    run_time(P["settle_time"], "settle")
    take_accumulators()
    run_time(min(P["sample_interval"], P["settle_time"]) if P["settle_time"] > 0 else P["sample_interval"], "settle")
    f, torque = take_accumulators()
    log("t=%.5f s settled at %.0f Pa after turning back %.4f rad: sigma = %.0f Pa, T = %.3g N m"
        % (O.time, stress, back, f / AREA, torque))


def base_spin():
    """Mean angular velocity about the axis (rad/s) of the particles whose centre lies in the layer
    just above the base or the ribs' tops (calibrax.core.sheartest.base_layer_bounds); NaN if empty."""
    z_lo, z_hi = P["base_layer"]
    total, count = 0.0, 0
    for i in sphere_ids:
        st = O.bodies[i].state
        x, y, z = st.pos[0], st.pos[1], st.pos[2]
        rho2 = x * x + y * y
        if z_lo <= z < z_hi and rho2 > 1e-18:
            total += (x * st.vel[1] - y * st.vel[0]) / rho2
            count += 1
    return total / count if count else float("nan")


def rotate(kind, stress, rotation, steady=None):
    """numba_dem's rotate: ``rotation`` rad; with ``steady`` = (first check, last sample, window,
    check every) in samples (calibrax.core.sheartest.steady_schedule, computed by the plugin) on
    until preshear_drift is within steady_tolerance or the last sample."""
    set_servo(stress, P["shear_speed_limit"])
    S["omega"] = RATE
    phi0 = S["phi"]
    per = NSUB * max(1, int(round(P["sample_interval"] / DT / NSUB)))
    nsamples = max(2, int(math.ceil(rotation / RATE / (per * DT))))
    if steady:
        first, nsamples, window, every = steady
    rec = {"kind": kind, "target_stress": stress, "time": [], "rotation": [], "force": [], "torque": [],
           "head_height": [], "wall_torque": [], "base_spin": []}
    take_accumulators()
    for k in range(nsamples):
        run_steps(per)
        f, torque = take_accumulators()
        rec["time"].append(O.time)
        rec["rotation"].append(S["phi"] - phi0)
        rec["force"].append(f)
        rec["torque"].append(torque)
        rec["head_height"].append(head_z())
        rec["wall_torque"].append(utils.sumTorques(wall_ids, (0, 0, 1), (0, 0, 0)))
        rec["base_spin"].append(base_spin())
        if k % 20 == 0:
            check(kind)
        if steady and k + 1 >= first and (k + 1 - first) % every == 0 and k + 1 < nsamples:
            # tau and sigma are the torque and force times constants, which the ratio cancels
            if preshear_drift(rec["torque"], rec["force"], window) <= P["steady_tolerance"]:
                break
    check(kind)
    S["omega"] = 0.0
    mean_sigma = sum(rec["force"]) / len(rec["force"]) / AREA
    err = mean_sigma / stress - 1.0
    SIGMA_ERR.append(err)
    log("t=%.5f s %s at %.0f Pa: mean sigma %.0f Pa (%+.1f %%), T max %.3g N m, head %.2f mm"
        % (O.time, kind, stress, mean_sigma, 100 * err, max(rec["torque"]), head_z() * 1e3))
    return rec


def run_stage(stage):
    """One stage of the parameter file's list (calibrax_yade.simulator.stage_params: core's
    shear_test_stages as data); the plugin refuses any stage not dispatched here before YADE starts."""
    name = stage["stage"]
    if name == "pour":
        pour()
    elif name == "insert_blades":
        insert_blades(stage["stress"])
    elif name == "consolidate":
        consolidate(stage["stress"])
    elif name == "settle":
        settle(stage["stress"])
    elif name == "rotate":
        steady = P["steady_schedule"] if stage["until_steady"] else None
        STEPS.append(rotate(stage["kind"], stage["stress"], stage["rotation"], steady))
        if stage["kind"] == "preshear":
            BULK.append(bulk())
    else:
        fail("crash", "the script cannot run a %r stage" % (name,))


def main():
    import yade.config
    log("YADE %s; %d particles, dt %.3e s, %d thread(s), servo every %d steps"
        % (yade.config.version, N, DT, O.numThreads, NSUB))
    for stage in P["stages"]:
        run_stage(stage)
    bad = [e for e in SIGMA_ERR if abs(e) > 0.05]
    if bad:
        WARN.append("the servo held sigma within 5 %% of its target in only %d of %d steps (worst %+.1f %%)"
                    % (len(SIGMA_ERR) - len(bad), len(SIGMA_ERR), 100 * max(bad, key=abs)))
    wall = time.time() - T_WALL0
    log("done: %.4f s simulated in %.1f s wall time, %d steps" % (O.time, wall, O.iter))
    write_json("result.json", {"yade_version": yade.config.version, "particles": N, "steps": STEPS,
                               "bulk_density": BULK, "warnings": WARN, "sigma_errors": SIGMA_ERR,
                               "insertion_gap_radii": INSERTION_GAP[0],
                               "simulated_time": O.time, "iterations": O.iter, "wall_time": wall,
                               "threads": O.numThreads})
    LOG.close()
    os._exit(0)


try:
    main()
except Exception as exc:  # any script error must come back as a failure with the log
    import traceback
    log(traceback.format_exc())
    fail("crash", "YADE script error: %r" % (exc,))
