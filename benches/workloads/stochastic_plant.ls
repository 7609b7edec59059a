/* Bench workload (stochastic): ABOP figure 1.27, three productions for F
   with probabilities 0.33 / 0.33 / 0.34 and a fixed seed. */
define: delta = 20
seed: 42

productions:
F -> F[+F]F[-F]F : 0.33
F -> F[+F]F : 0.33
F -> F[-F]F : 0.34

axiom:
F
