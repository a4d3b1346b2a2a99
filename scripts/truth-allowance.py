#!/usr/bin/env python3
"""The truth's own tilt error of recordings, measured where the accelerometer is the best tilt reference there is: at
rest, it measures gravity (and its own small error). Per rest period (the gyro within 0.03 rad/s of its opening
median for at least 0.5 s), the angle between the accelerometer's mean direction and the truth's vertical (carried
into VQF's frames for a truth with its own frames, `align: both`, docs/recordings.md). The per-axis 1σ, RMS/√2, is
the allowance the scores add for the truth (`truth_tilt_sigma_deg`).

    .venv/bin/python scripts/truth-allowance.py RECORDING.hdf5|RECORDING.csv [...]
"""
import sys

import numpy as np

from attitude_client.replay import alignment, invquat, load_trial, quatmult, rotation_matrix, run_vqf
def rests(g, rate, thr=0.03, min_s=0.5):
    still = np.linalg.norm(g - np.median(g[:max(5,int(rate))],0),axis=1) < thr
    out=[]; k=0; n=len(g)
    while k<n:
        if still[k]:
            j=k
            while j<n and still[j]: j+=1
            if (j-k)/rate>=min_s: out.append((k,j))
            k=j
        else: k+=1
    return out
allerr=[]
if len(sys.argv) < 2:
    sys.exit(__doc__)
for p in sys.argv[1:]:
    tr=load_trial(p,None)
    q=run_vqf(tr)
    truth=tr['opt_quat']
    ok=tr['movement']&np.isfinite(truth).all(1)
    if tr['truth']['align']=='both':
        l,r=alignment(q[ok],truth[ok]); qt=quatmult(quatmult(invquat(l),truth),invquat(r))
    else: qt=truth
    R=rotation_matrix(qt)
    up_body=np.einsum('nji,j->ni',R,np.array([0,0,1.0]))
    errs=[]
    for k,j in rests(tr['gyr'],tr['rate_hz']):
        a=tr['acc'][k:j].mean(0); u=np.nanmean(up_body[k:j],0)
        if not np.isfinite(u).all(): continue
        u/=np.linalg.norm(u); a/=np.linalg.norm(a)
        errs.append(np.rad2deg(np.arccos(np.clip(a@u,-1,1))))
    allerr+=errs
    print(f"{tr['name'][:36]:36s} rests {len(errs)} tilt acc-vs-truth deg {np.round(errs,2)}")
e=np.array(allerr); print(f"ALL: n {len(e)} rms {np.sqrt((e**2).mean()):.2f} per-axis sigma {np.sqrt((e**2).mean()/2):.2f} median {np.median(e):.2f}")
