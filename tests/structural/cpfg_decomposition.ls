/* Decomposition as the cpfg manual describes it (section 4.4): the
   productions grow the main building blocks (apex A, internode I, leaf L);
   after each step, before interpretation, decomposition replaces each leaf
   by its parts, and the parts stay in the string (F keeps growing). As in
   cpfg, the axiom is not decomposed. */
derivation length: 2

productions:
A -> ILA
F -> FF

decomposition:
L -> [+F][-F]

axiom:
LA
