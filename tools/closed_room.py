#!/usr/bin/env python3
"""A scene the project was not built against: a closed room (camera inside, one-sided walls
facing in, a dark floor, red and green side walls) with a clear glass cube (ior 1.33) under a
15 cd sphere light (radius 0.15 m, so that a path tracer finds the caustic through the cube,
which it cannot from a point light). Its few big triangles overflow a deep cubemap's
first-guess lists.

    python3 tools/closed_room.py out/room.gltf
    python3 tools/reference.py out/room.gltf --out out/room.ref.exr --width 128 --height 128 --spp 16384
"""
import base64
import json
import struct
import sys

W,H,D=4.0,3.0,4.0
meshes=[]; buf=b''; views=[]; accs=[]; nodes=[]; mats=[]
def add_mesh(quads, mat):
    global buf
    pos=[];nor=[];idx=[]
    for (p0,p1,p2,p3,n) in quads:
        b=len(pos)
        pos+= [p0,p1,p2,p3]; nor+=[n]*4
        idx+=[b,b+1,b+2,b,b+2,b+3]
    def push(data,fmt,target,count,typ,comp,minmax=None):
        global buf
        off=len(buf); raw=b''.join(struct.pack(fmt,*d) if isinstance(d,(list,tuple)) else struct.pack(fmt,d) for d in data)
        buf+=raw
        while len(buf)%4: buf+=b'\0'
        views.append({"buffer":0,"byteOffset":off,"byteLength":len(raw),"target":target})
        a={"bufferView":len(views)-1,"componentType":comp,"count":count,"type":typ}
        if minmax: a["min"],a["max"]=minmax
        accs.append(a); return len(accs)-1
    mn=[min(p[i] for p in pos) for i in range(3)]; mx=[max(p[i] for p in pos) for i in range(3)]
    pa=push(pos,'<3f',34962,len(pos),"VEC3",5126,(mn,mx)); na=push(nor,'<3f',34962,len(nor),"VEC3",5126)
    ia=push(idx,'<I',34963,len(idx),"SCALAR",5125)
    meshes.append({"primitives":[{"attributes":{"POSITION":pa,"NORMAL":na},"indices":ia,"material":mat}]})
    nodes.append({"mesh":len(meshes)-1})
def mat(rgb, **kw):
    m={"pbrMetallicRoughness":{"baseColorFactor":rgb+[1.0],"metallicFactor":0.0,"roughnessFactor":1.0},"doubleSided":False}
    m.update(kw); mats.append(m); return len(mats)-1
white=mat([0.7,0.7,0.7]); dark=mat([0.15,0.12,0.1]); red=mat([0.7,0.15,0.1]); green=mat([0.15,0.6,0.15])
glass=mat([1,1,1],extensions={"KHR_materials_transmission":{"transmissionFactor":1.0},"KHR_materials_ior":{"ior":1.33}})
mats[glass]["pbrMetallicRoughness"]["roughnessFactor"]=0.0
x0,x1,y0,y1,z0,z1=-W/2,W/2,0,H,-D/2,D/2
# inward-facing walls (counter-clockwise seen from inside)
add_mesh([([x0,y0,z0],[x0,y0,z1],[x1,y0,z1],[x1,y0,z0],[0,1,0])],dark)        # floor
add_mesh([([x0,y1,z0],[x1,y1,z0],[x1,y1,z1],[x0,y1,z1],[0,-1,0])],white)      # ceiling
add_mesh([([x0,y0,z0],[x1,y0,z0],[x1,y1,z0],[x0,y1,z0],[0,0,1])],white)       # back
add_mesh([([x0,y0,z1],[x0,y1,z1],[x1,y1,z1],[x1,y0,z1],[0,0,-1])],white)      # front (behind camera)
add_mesh([([x0,y0,z0],[x0,y1,z0],[x0,y1,z1],[x0,y0,z1],[1,0,0])],red)         # left
add_mesh([([x1,y0,z0],[x1,y0,z1],[x1,y1,z1],[x1,y1,z0],[-1,0,0])],green)      # right
# glass cube, outward faces
c=[0.3,0.005,-0.5]; s=0.35  # 5 mm above the floor: no coplanar contact
def v(dx,dy,dz): return [c[0]+dx*s,c[1]+s+dy*s,c[2]+dz*s]
cube=[(v(-1,-1,1),v(1,-1,1),v(1,1,1),v(-1,1,1),[0,0,1]),(v(1,-1,-1),v(-1,-1,-1),v(-1,1,-1),v(1,1,-1),[0,0,-1]),
      (v(1,-1,1),v(1,-1,-1),v(1,1,-1),v(1,1,1),[1,0,0]),(v(-1,-1,-1),v(-1,-1,1),v(-1,1,1),v(-1,1,-1),[-1,0,0]),
      (v(-1,1,1),v(1,1,1),v(1,1,-1),v(-1,1,-1),[0,1,0]),(v(-1,-1,-1),v(1,-1,-1),v(1,-1,1),v(-1,-1,1),[0,-1,0])]
add_mesh(cube,glass)
nodes.append({"extensions":{"KHR_lights_punctual":{"light":0}},"translation":[-0.6,2.6,0.3]})
nodes.append({"camera":0,"translation":[0.0,1.4,1.8],"rotation":[-0.1305,0,0,0.9914]})
g={"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":list(range(len(nodes)))}],"nodes":nodes,"meshes":meshes,
 "materials":mats,"accessors":accs,"bufferViews":views,
 "buffers":[{"byteLength":len(buf),"uri":"data:application/octet-stream;base64,"+base64.b64encode(buf).decode()}],
 "cameras":[{"type":"perspective","perspective":{"yfov":1.0,"znear":0.05,"zfar":100.0,"aspectRatio":1.0}}],
 "extensionsUsed":["KHR_lights_punctual","KHR_materials_transmission","KHR_materials_ior"],
 "extensions":{"KHR_lights_punctual":{"lights":[{"type":"point","color":[1,1,1],"intensity":15.0,"extras":{"rppm_radius":0.15}}]}}}
with open(sys.argv[1] if len(sys.argv) > 1 else 'room.gltf', 'w') as f:
    json.dump(g, f)
