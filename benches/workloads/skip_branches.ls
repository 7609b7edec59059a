/* Bench workload (right context over huge branches): in the axiom given
   with --axiom (made by skip_axiom.ls), each A must skip the whole branch
   that follows it to find its right context B. */
productions:
A > B -> C

axiom:
A[F]B
