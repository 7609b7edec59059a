/* view file: the function and curve lines matter to lsgen */
angle factor: 12
contour sides: 7
curve: dome.con 50
function: radius.func
scale factor: 0.9
curve: tilt.con
