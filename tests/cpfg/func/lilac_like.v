/* view file: only the function lines matter to lsgen */
angle factor: 10
initial color: 1
function: angle.func 100
function: elasticity.func
