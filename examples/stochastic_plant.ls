/* Stochastic bracketed OL-system, ABOP figure 1.27 (p. 29), n = 5.
   The book does not give the angle for this figure; delta = 20 is a choice
   made here for renderers.  Each step picks one of the three F productions
   with probabilities 0.33 / 0.33 / 0.34; the seed makes runs repeatable. */
view: angle = 20
view: width = 0.2
view: palette = #33691e
derivation length: 5
define: delta = 20
seed: 42

productions:
F -> F[+F]F[-F]F : 0.33
F -> F[+F]F : 0.33
F -> F[-F]F : 0.34

axiom:
F
