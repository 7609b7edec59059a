/* Sympodial tree (Aono and Kunii's model), ABOP figure 2.7b (p. 59), n = 10.
   Table of figure 2.7: (a) r2 = 0.7, a1 = 5, a2 = 65; (b) r2 = 0.7,
   a1 = 10, a2 = 60; (c) r2 = 0.8, a1 = 20, a2 = 50; (d) r2 = 0.8,
   a1 = 35, a2 = 35 (r1 = 0.9 throughout). */
view: width scale = 0.02   /* !(w) gives widths in cpfg's pixels */
view: palette = #4e342e
view: direction = 0 10
derivation length: 10
define: r1 = 0.9     /* contraction ratio 1 */
define: r2 = 0.7     /* contraction ratio 2 */
define: a1 = 10      /* branching angle 1 */
define: a2 = 60      /* branching angle 2 */
define: wr = 0.707   /* width decrease rate */

productions:
A(l,w) -> !(w)F(l)[&(a1)B(l*r1,w*wr)]/(180)[&(a2)B(l*r2,w*wr)]
B(l,w) -> !(w)F(l)[+(a1)$B(l*r1,w*wr)][-(a2)$B(l*r2,w*wr)]

axiom:
A(1,10)
