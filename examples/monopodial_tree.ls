/* Monopodial tree (Honda's model), ABOP figure 2.6a (p. 56), n = 10.
   Table of figure 2.6: (a) r2 = 0.6, a0 = 45, a2 = 45; (b) r2 = 0.9;
   (c) r2 = 0.8; (d) r2 = 0.7, a0 = 30, a2 = -30 (r1 = 0.9 throughout). */
view: width scale = 0.02   /* !(w) gives widths in cpfg's pixels */
view: palette = #4e342e
view: direction = 0 10
derivation length: 10
define: r1 = 0.9     /* contraction ratio for the trunk */
define: r2 = 0.6     /* contraction ratio for branches */
define: a0 = 45      /* branching angle from the trunk */
define: a2 = 45      /* branching angle for lateral axes */
define: d = 137.5    /* divergence angle */
define: wr = 0.707   /* width decrease rate */

productions:
A(l,w) -> !(w)F(l)[&(a0)B(l*r2,w*wr)]/(d)A(l*r1,w*wr)
B(l,w) -> !(w)F(l)[-(a2)$C(l*r2,w*wr)]C(l*r1,w*wr)
C(l,w) -> !(w)F(l)[+(a2)$B(l*r2,w*wr)]B(l*r1,w*wr)

axiom:
A(1,10)
