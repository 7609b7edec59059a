/* Three-dimensional bush-like structure, ABOP figure 1.25 (p. 26).
   n = 7, delta = 22.5 degrees.  Each apex A makes three branches;
   ' raises the colour index, ! thins the branches, and the leaves L are
   polygons {...} whose vertices f records (cpfg's rule). */
view: angle = 22.5
view: step = 1
view: width = 0.45
view: width increment = 0.06
view: palette = #5d4037 #6d4c41 #33691e #558b2f #689f38 #7cb342 #8bc34a #9ccc65
view: direction = 20 10
derivation length: 7

productions:
A -> [&FL!A]/////'[&FL!A]///////'[&FL!A]
F -> S/////F
S -> FL
L -> ['''^^{-f+f+f-|-f+f+f}]

axiom:
A
