/* Parametric production with contexts, ABOP section 1.10.1 (p. 42):
   A(x) < B(y) > C(z) : x+y+z > 10 -> E((x+y)/2)F((y+z)/2)
   In A(4)B(5)C(6) the module B(5) becomes E(4.5)F(5.5); in A(1)B(2)C(3)
   the condition fails and B(2) is left alone.  After one step:
   A(4)E(4.5)F(5.5)C(6)A(1)B(2)C(3) */
view: step = 1   /* E(4.5)F(5.5): one segment of length 5.5 */
derivation length: 1

productions:
A(x) < B(y) > C(z) : x+y+z > 10 -> E((x+y)/2)F((y+z)/2)

axiom:
A(4)B(5)C(6)A(1)B(2)C(3)
