/* Context matching in a bracketed string, ABOP section 1.8 (p. 32):
   in ABC[DE][SG[HI[JK]L]MNO] the module S has left context BC and right
   context G[H]M.  Each production below tests one rule of context
   matching; the ones marked "no" must not apply.  After one step:
   aBc[de][sg[hi[jk]l]mno] */
view: step = 1   /* letters only: nothing is drawn */
derivation length: 1

productions:
D -> Q                  /* context-free: loses to the match below */
N -> Q                  /* context-free: loses to the match below */
BC < S > G[H]M -> s     /* the book's example */
A > BC[DE] -> a         /* ']' in a pattern skips the rest of the branch */
C > [S -> c             /* one of several sibling branches may match */
C < D > E -> d          /* left of D: '[' is stepped over, parent is C */
D < E -> e
S < G -> g
G < H -> h
I < J -> j
J < K -> k
I > L -> i              /* the branch [JK] is skipped */
K < L -> z              /* no: the branch [JK] is skipped leftwards too */
I < L -> l
L < M -> y              /* no: the branch [HI[JK]L] is skipped */
G < M -> m
L > M -> x              /* no: ']' ends the search for a right context */
M < N > O -> n
O -> o
O > A -> w              /* no: O is the last module of its branch */

axiom:
ABC[DE][SG[HI[JK]L]MNO]
