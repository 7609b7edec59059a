/* view file: the function set is the only function line (cpfg defines
   the names as macros only if the set is the last function line) */
angle factor: 12
function set: shapes.fset
