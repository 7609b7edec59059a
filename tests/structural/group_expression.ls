/* A group schedule given by an expression of the step number: odd steps
   use group 1, even steps group 2 (docs/structural.md, sections 6 and 7). */
derivation length: 4
group: 1 + (floor(step / 2) == step / 2)

productions 1:
A -> A[+B(step)]

productions 2:
A -> A[-C(step)]

axiom:
A
