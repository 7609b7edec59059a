/* A compound leaf made by decomposition (docs/structural.md, section 2).
   The productions only grow the shoot: the apex A(n) makes an internode and
   two leaves L(n) with n pairs of leaflets. Decomposition turns a leaf into
   a rachis segment F with a pair of leaflets P and a smaller leaf, three
   levels per step; what the depth limit leaves (P, L(k)) is decomposed in
   the next step. A leaflet P becomes [&K]. */
view: angle = 45
view: direction = side
derivation length: 3

productions:
A(n) -> I[+L(n)][-L(n)]A(n+1)

decomposition:
maximum depth: 3
L(n) : n > 0 -> F[+P][-P]L(n-1)
L(n) : n == 0 -> P
P -> [&K]

axiom:
A(1)
