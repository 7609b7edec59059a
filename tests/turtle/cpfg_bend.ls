/* lsgen-turtle test model: cpfg's tropism (`view: tropism model =
   cpfg`): the bend after F, G, f and g, and `_` changing the elasticity,
   kept by branches. Its segments are checked against
   tests/tools/turtle.py, and cpfg_bend.v says the same in cpfg's view-file
   syntax (tests/turtle.rs). */
view: angle = 30
view: tropism = 0.3 -1 0.2
view: elasticity = 0.12
view: elasticity increment = 0.02
view: tropism model = cpfg
view: colour = 3
view: width = 2
view: width increment = 0.5

productions:
A -> F[&+!A]f[^-_A]/(45)_(0.05)G[\#A]gA

axiom:
A
