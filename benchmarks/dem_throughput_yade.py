# calibrax dem_throughput: the settled bed in the cylinder, timed inside YADE, run as
#     yade -n -j THREADS -x dem_throughput_yade.py PARAMS.json
# This file is fixed (never generated). Every number comes from the JSON parameter file written
# and validated by benchmarks/dem_throughput.py (calibrax_yade.runner.write_params); the timings go
# to result.json (or failure.json), next to the parameter file.
#
# Contact law and facet material as the yade backend (calibrax_yade.contact): Hertz-Mindlin with
# restitution damping (en, es), constant rolling stiffness krot and limit eta. Walls: the backend's facet
# vessel and one-facet base. The collider keeps YADE's default Verlet distance.
import json
import math
import os
import sys
import time

import yade
from yade import utils

PARAMS_PATH = os.path.abspath(sys.argv[1])
WD = os.path.dirname(PARAMS_PATH)
with open(PARAMS_PATH) as fh:
    P = json.load(fh)


def write_json(name, data):
    tmp = os.path.join(WD, name + ".tmp")
    with open(tmp, "w") as fh:
        json.dump(data, fh)
    os.replace(tmp, os.path.join(WD, name))


# the yade backend's collision masks (scripts/ft4_shear.py): facets never meet facets
SPHERE_MASK, FACET_MASK, NO_SELF_MASK = 1, 3, 2


def add_facets(flat, material):
    for k in range(0, len(flat), 9):
        v = flat[k:k + 9]
        O.bodies.append(utils.facet([(v[0], v[1], v[2]), (v[3], v[4], v[5]), (v[6], v[7], v[8])],
                                    material=material, fixed=True, wire=True, mask=FACET_MASK))


try:
    mat_p = O.materials.append(FrictMat(young=P["young"], poisson=P["poisson"], density=P["density"],
                                        frictionAngle=math.atan(P["friction"])))
    mat_w = O.materials.append(FrictMat(young=P["facet_young"], poisson=P["facet_poisson"], density=P["density"],
                                        frictionAngle=math.atan(P["wall_friction"])))
    mat_b = O.materials.append(FrictMat(young=P["facet_young"], poisson=P["facet_poisson"], density=P["density"],
                                        frictionAngle=math.atan(P["base_friction"])))
    add_facets(P["vessel_facets"], mat_w)
    add_facets(P["base_facets"], mat_b)
    pos, vel, spin, radii = P["positions"], P["velocities"], P["spins"], P["radii"]
    for i, r in enumerate(radii):
        b = utils.sphere((pos[3 * i], pos[3 * i + 1], pos[3 * i + 2]), r, material=mat_p, mask=SPHERE_MASK)
        b.state.vel = Vector3(vel[3 * i], vel[3 * i + 1], vel[3 * i + 2])
        b.state.angVel = Vector3(spin[3 * i], spin[3 * i + 1], spin[3 * i + 2])
        O.bodies.append(b)
    frict = MatchMaker(matches=((mat_p, mat_p, math.atan(P["friction"])), (mat_p, mat_w, math.atan(P["wall_friction"])),
                                (mat_p, mat_b, math.atan(P["base_friction"]))), algo="min")
    ip2 = Ip2_FrictMat_FrictMat_MindlinPhys(en=MatchMaker(matches=(), algo="val", val=P["restitution"]),
                                            es=MatchMaker(matches=(), algo="val", val=P["shear_restitution"]),
                                            krot=P["krot"], ktwist=0.0, eta=P["eta"], frictAngle=frict)
    O.engines = [ForceResetter(),
                 InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Facet_Aabb()], avoidSelfInteractionMask=NO_SELF_MASK),
                 InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Facet_Sphere_ScGeom()], [ip2],
                                 [Law2_ScGeom_MindlinPhys_Mindlin(includeMoment=True)]),
                 NewtonIntegrator(gravity=(0, 0, -P["gravity"]), damping=0.0)]
    O.dt = P["dt"]
    step = O.step
    for _ in range(int(P["warmup_steps"])):
        step()
    timings = []
    for _ in range(int(P["repeats"])):
        t0 = time.perf_counter()
        for _ in range(int(P["steps"])):
            step()
        timings.append(time.perf_counter() - t0)
    n = len(radii)
    write_json("result.json", {"seconds": timings, "steps": int(P["steps"]), "particles": n,
                               "yade_version": str(yade.config.version)})
except Exception as exc:  # reported to the caller through failure.json
    write_json("failure.json", {"kind": "crash", "reason": repr(exc)})
    os._exit(3)
os._exit(0)
