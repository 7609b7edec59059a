/* View file of clipped.l, in cpfg's syntax: lsgen --cpfg-view (the turtle
   of the queries) and lsgen-turtle --cpfg-view (the picture). */
angle increment: 30
initial color: 2
initial line width: 1 pixels
viewpoint: 0,0,1
view reference point: 0,0,0
projection: parallel
