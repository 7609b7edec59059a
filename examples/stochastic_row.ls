/* A row of stochastic plants, after ABOP figure 1.27 (p. 29): five trees
   from one seeded derivation of the stochastic rules of
   stochastic_plant.ls (n = 5, delta = 20 degrees), standing 70 units
   apart.  Another seed gives another row, always the same for one seed. */
view: angle = 20
view: width = 1.0
view: palette = #33691e
derivation length: 5
seed: 7

productions:
F -> F[+F]F[-F]F : 0.33
F -> F[+F]F : 0.33
F -> F[-F]F : 0.34

axiom:
[F]-(90)f(70)+(90)[F]-(90)f(70)+(90)[F]-(90)f(70)+(90)[F]-(90)f(70)+(90)[F]
