/* cpfg_bend.ls's view settings in cpfg's view-file syntax (a test of
   lsgen-turtle --cpfg-view): drawn, both give the same segments. */
#define ANGLE 30
angle increment: ANGLE
tropism direction: 0.3,-1,0.2   // normalised, as cpfg does
initial elasticity: 0.12
elasticity increment: 0.02
initial color: 3
color increment: 1
initial line width: 2
line width increment: 0.5
viewpoint: 0,0,1
view reference point: 0,0,0
twist: 0
projection: parallel
z buffer: on
light: V: 0.5,1.0,3.0
function: none.func
