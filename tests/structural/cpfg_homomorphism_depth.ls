/* The cpfg manual's recursive homomorphism (sections 4.3.1 and 4.3.2):
   with maximum depth 2, F becomes G P(0,0) and G becomes f when the module
   after the original F in the derived string is a P whose y exceeds 3. The
   context is the original P, never the P(0,0) the homomorphism made. */
derivation length: 2

productions:
P(x,y) -> P(x,y+1)

homomorphism: warnings
maximum depth: 2
F -> G P(0,0)
G > P(x,y) : y > 3 -> f

axiom:
F P(1,5) F P(1,2)
