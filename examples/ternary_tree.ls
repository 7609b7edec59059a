/* Ternary branching tree, ABOP figure 2.8a (p. 60), n = 6.
   The book bends the branches by tropism (T = 0,-1,0, e = 0.22): the
   view lines below hand T and e to lsgen-turtle.  Old segments keep elongating (F) and
   thickening (!) every step. */
view: tropism = 0 -1 0
view: elasticity = 0.22
view: width scale = 1.5
view: palette = #4e342e
view: direction = 0 0
derivation length: 6
define: d1 = 94.74   /* divergence angle 1 */
define: d2 = 132.63  /* divergence angle 2 */
define: a = 18.95    /* branching angle */
define: lr = 1.109   /* elongation rate */
define: vr = 1.732   /* width increase rate */

productions:
A -> !(vr)F(50)[&(a)F(50)A]/(d1)[&(a)F(50)A]/(d2)[&(a)F(50)A]
F(l) -> F(l*lr)
!(w) -> !(w*vr)

axiom:
!(1)F(200)/(45)A
