"""The mode filter run at the depth's own resolution (docs/build.md, ninth session): for each scene and
kind of an earlier `depth_quality.py --tag plane` run, the colour area-averaged to the depth's size,
`pomc prepare --refine mode` there, then `pomc prepare` onto the full colour; flying share and F1@2.

    target/bpy-venv/bin/python docs/trials/lowres_mode.py BIN mono,low4
"""
import sys, os, subprocess, json, numpy as np
sys.path.insert(0,'tools/eval'); sys.path.insert(0,'tools/eval/realistic')
import depth_quality as dq
import run as realistic
import OpenEXR
BIN=os.path.abspath(sys.argv[1]); kinds=sys.argv[2].split(','); extra=sys.argv[3:] 
W='target/depth-quality/85b5eb16750c/plane'
def write_rgb(path, im):
    h,w,_=im.shape
    hdr={"compression":OpenEXR.ZIP_COMPRESSION,"type":OpenEXR.scanlineimage}
    ch={"R":im[...,0].astype(np.float32),"G":im[...,1].astype(np.float32),"B":im[...,2].astype(np.float32)}
    with OpenEXR.File(hdr,ch) as f: f.write(path)
for scene in ['room','outdoor','extreme']:
    truth=realistic.read_channels(f'target/realistic-corpus/85b5eb16750c/{scene}/depth.exr')['Z']
    for k in kinds:
        c=realistic.read_channels(f'{W}/{scene}/input-{k}-colour.exr')
        col=np.stack([c['R'],c['G'],c['B']],-1)
        dpath=f'{W}/{scene}/input-{k}-depth.exr'
        d=realistic.read_channels(dpath)['Z']
        f=col.shape[0]//d.shape[0]
        out=f'/tmp/lrm/{scene}-{k}'; os.makedirs(out,exist_ok=True)
        if f>1 and os.environ.get('SMALL','1')=='1':
            small=col.reshape(d.shape[0],f,d.shape[1],f,3).mean((1,3))
            write_rgb(f'{out}/col-small.exr',small)
            subprocess.run([BIN,'prepare','--colour',f'{out}/col-small.exr','--depth',dpath,*os.environ.get('SMALLARGS','--refine mode').split(),'-o',f'{out}/d-small.exr','--quiet',*extra],check=True)
            src=f'{out}/d-small.exr'
        else:
            src=dpath
        subprocess.run([BIN,'prepare','--colour',f'{W}/{scene}/input-{k}-colour.exr','--depth',src,'-o',f'{out}/prep.exr','--quiet'],check=True)
        prep=realistic.read_channels(f'{out}/prep.exr')['Z']
        fly,nan=dq.flying(prep,truth)
        print(scene,k,'factor',f,'flying %.3f'%(100*fly.mean()),'F1@2 %.3f'%dq.boundary_f1(prep,truth,2),flush=True)
