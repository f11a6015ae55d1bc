# calibrax-yade verification: one sphere on a flat base facet under gravity, run as
#     yade -n -j 1 -x sphere_on_base.py PARAMS.json
# Fixed file; every number comes from the JSON parameter file. The base is one large facet with
# the shear test's fictitious facet material and the shear test's contact law (Mindlin, en = e,
# es = shear_restitution, constant krot, eta); the sphere starts at its static overlap with a
# velocity and a spin. Writes result.json next to the parameter file: rows (step, vx, wx) sampled
# every `every` steps.
import json
import math
import os
import sys

from yade import utils

PARAMS_PATH = os.path.abspath(sys.argv[1])
WD = os.path.dirname(PARAMS_PATH)
with open(PARAMS_PATH) as fh:
    P = json.load(fh)

r = P["radius"]
mat_p = O.materials.append(FrictMat(young=P["young"], poisson=P["poisson"], density=P["density"],
                                    frictionAngle=math.atan(P["friction"])))
mat_b = O.materials.append(FrictMat(young=P["facet_young"], poisson=P["facet_poisson"], density=P["density"],
                                    frictionAngle=math.atan(P["friction"])))
half = P["half_width"]
base = O.bodies.append(utils.facet([(-half, -half, 0.0), (2.0 * half, -half, 0.0), (-half, 2.0 * half, 0.0)],
                                   material=mat_b, fixed=True, wire=True))
s = O.bodies.append(utils.sphere((0.0, 0.0, P["z0"]), r, material=mat_p))
O.bodies[s].state.vel = Vector3(*P["velocity"])
O.bodies[s].state.angVel = Vector3(*P["spin"])
ip2 = Ip2_FrictMat_FrictMat_MindlinPhys(en=MatchMaker(matches=(), algo="val", val=P["restitution"]),
                                        es=MatchMaker(matches=(), algo="val", val=P["shear_restitution"]),
                                        krot=P["krot"], ktwist=0.0, eta=P["eta"])
rows = []


def sample():
    rows.append((O.iter, O.bodies[s].state.vel[0], O.bodies[s].state.angVel[0]))


O.engines = [ForceResetter(),
             InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Facet_Aabb()]),
             InteractionLoop([Ig2_Facet_Sphere_ScGeom()], [ip2], [Law2_ScGeom_MindlinPhys_Mindlin(includeMoment=True)]),
             NewtonIntegrator(gravity=(0, 0, -P["gravity"]), damping=0.0),
             PyRunner(iterPeriod=int(P["every"]), initRun=True, command="sample()")]
O.dt = P["dt"]
O.run(int(P["nsteps"]), True)
import yade.config

tmp = os.path.join(WD, "result.json.tmp")
with open(tmp, "w") as fh:
    json.dump({"rows": rows, "yade_version": yade.config.version}, fh)
os.replace(tmp, os.path.join(WD, "result.json"))
os._exit(0)
