# calibrax-yade verification: head-on impact of two equal spheres (no gravity), run as
#     yade -n -j 1 -x two_spheres.py PARAMS.json
# Fixed file; every number comes from the JSON parameter file. Writes result.json next to it:
# contact time (steps with overlap > 0, times dt), peak overlap, relative velocities in and out,
# kinetic energies, and the contact's YADE coefficients (kno, kso, betan) for checking the conversion.
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
e = P["restitution"]
mat = O.materials.append(FrictMat(young=P["young"], poisson=P["poisson"], density=P["density"],
                                  frictionAngle=math.atan(0.5)))
gap = P["gap"]
a = O.bodies.append(utils.sphere((-r - gap, 0, 0), r, material=mat))
b = O.bodies.append(utils.sphere((r + gap, 0, 0), r, material=mat))
O.bodies[a].state.vel = Vector3(0.5 * P["speed"], 0, 0)
O.bodies[b].state.vel = Vector3(-0.5 * P["speed"], 0, 0)
O.engines = [ForceResetter(),
             InsertionSortCollider([Bo1_Sphere_Aabb()]),
             InteractionLoop([Ig2_Sphere_Sphere_ScGeom()],
                             [Ip2_FrictMat_FrictMat_MindlinPhys(en=MatchMaker(matches=(), algo="val", val=e),
                                                                es=MatchMaker(matches=(), algo="val", val=e))],
                             [Law2_ScGeom_MindlinPhys_Mindlin(includeMoment=True)]),
             NewtonIntegrator(gravity=(0, 0, 0), damping=0.0)]
O.dt = P["dt"]


def kinetic():
    return sum(0.5 * O.bodies[i].state.mass * O.bodies[i].state.vel.squaredNorm() for i in (a, b))


ke0 = kinetic()
in_contact = 0
touched = False
peak = 0.0
kno = kso = betan = float("nan")
for _ in range(int(P["max_steps"])):
    O.step()
    overlap = 2.0 * r - (O.bodies[b].state.pos[0] - O.bodies[a].state.pos[0])
    if overlap > 0.0:
        in_contact += 1
        touched = True
        peak = max(peak, overlap)
        if not math.isfinite(kno):
            for I in O.interactions:
                if I.isReal:
                    kno, kso, betan = I.phys.kno, I.phys.kso, I.phys.betan
    elif touched:
        break
v_out = O.bodies[b].state.vel[0] - O.bodies[a].state.vel[0]
import yade.config

out = {"contact_steps": in_contact, "v_out": v_out, "ke0": ke0, "ke1": kinetic(), "peak_overlap": peak, "kno": kno, "kso": kso, "betan": betan,
       "yade_version": yade.config.version}
tmp = os.path.join(WD, "result.json.tmp")
with open(tmp, "w") as fh:
    json.dump(out, fh)
os.replace(tmp, os.path.join(WD, "result.json"))
os._exit(0)
