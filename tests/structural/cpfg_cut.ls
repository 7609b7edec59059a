/* The cpfg manual's cut example (section 6.4): a branch [D(age)...] ages
   one unit per step; at age 20 D becomes the cut symbol %, which removes
   the rest of the branch in the next step (the brackets stay). */
derivation length: 5

productions:
D(a) : a < 20 -> D(a+1)
D(a) : a >= 20 -> %

axiom:
F[+D(1)F]F[-D(17)F]F
