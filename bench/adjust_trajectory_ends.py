#!/usr/bin/env python3
"""Bench: the mobile LiDAR trajectory correction per node against the simulator's truth.

  bench/adjust_trajectory_ends.py SIM_DIR ADJUST_OUTPUT [all]

For each node of ADJUST_OUTPUT/mls_trajectory.csv: the corrected pose's position and rotation
error against SIM_DIR/truth/trajectory_true.csv (linear in time between its rows), the
GNSS/INS pose's (SIM_DIR/trajectory_ins.csv), the stated sigma, and the mobile points and rig
frames that observe the node. Without `all`: the first 3 and the last 6 nodes (the drive's ends).
"""
import numpy as np, csv, sys
def qm(w,x,y,z):
    n=np.sqrt(w*w+x*x+y*y+z*z); w,x,y,z=w/n,x/n,y/n,z/n
    return np.array([[1-2*(y*y+z*z),2*(x*y-z*w),2*(x*z+y*w)],[2*(x*y+z*w),1-2*(x*x+z*z),2*(y*z-x*w)],[2*(x*z-y*w),2*(y*z+x*w),1-2*(x*x+y*y)]])
def exp(w):
    th=np.linalg.norm(w)
    if th<1e-12: return np.eye(3)
    k=w/th; K=np.array([[0,-k[2],k[1]],[k[2],0,-k[0]],[-k[1],k[0],0]])
    return np.eye(3)+np.sin(th)*K+(1-np.cos(th))*K@K
def ang(Rm): return np.degrees(np.arccos(np.clip((np.trace(Rm)-1)/2,-1,1)))
def load(p):
    rows=[r for r in csv.reader(l for l in open(p) if not l.startswith('#'))][1:]
    return np.array([[float(x) for x in r] for r in rows])
sim,out=sys.argv[1],sys.argv[2]
tru=load(sim+'/truth/trajectory_true.csv'); ins=load(sim+'/trajectory_ins.csv')
adj=[r for r in csv.DictReader(l for l in open(out+'/mls_trajectory.csv') if not l.startswith('#'))]
def at(tab,t):
    i=np.searchsorted(tab[:,0],t); i=min(max(i,1),len(tab)-1); a,b=tab[i-1],tab[i]; f=(t-a[0])/(b[0]-a[0])
    return a[1:4]+f*(b[1:4]-a[1:4]), qm(*((1-f)*a[4:8]+f*b[4:8]))
sel=adj[:3]+adj[-6:] if len(sys.argv)<4 else adj
for r in sel:
    t=float(r['time_s']); pt,Rt=at(tru,t); pi,Ri=at(ins,t)
    om=np.radians([float(r['omega_x_deg']),float(r['omega_y_deg']),float(r['omega_z_deg'])])
    Ra=exp(om)@Ri; pa=pi+np.array([float(r['delta_east_m']),float(r['delta_north_m']),float(r['delta_up_m'])])
    print("t %5.2f adj %5.0f mm %.2f°  ins %5.0f mm %.2f°  sig %.0f mm %.2f°  pts %s rig %s"%(t,1000*np.linalg.norm(pa-pt),ang(Ra@Rt.T),1000*np.linalg.norm(pi-pt),ang(Ri@Rt.T),1000*float(r['sigma_delta_m']),float(r['sigma_omega_deg']),r['points'],r['rig_frames']))
