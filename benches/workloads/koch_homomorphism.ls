/* Bench workload (homomorphism): the Koch snowflake, then a homomorphism
   that replaces every module of the last generation by parametric ones. */
define: delta = 60

productions:
F -> F+F--F+F

homomorphism:
F -> G(1)H(2)
+ -> +(delta)
- -> -(delta)

axiom:
F--F--F
