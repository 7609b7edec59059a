/* View file of weeping.l, in cpfg's syntax (lsgen-turtle --cpfg-view). */
angle increment: 30
initial color: 1
initial line width: 1 pixels
line width increment: 1
tropism direction: 0,-1,0      /* gravity */
initial elasticity: -0.15      /* young wood bends up a little */
elasticity increment: 0.1      /* each level bends down more */
viewpoint: 0,0,1
view reference point: 0,0,0
twist: 0
projection: parallel
