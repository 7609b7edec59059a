//! cpfg's turtle queries `?P`, `?H`, `?L`, `?U` through the real binary
//! (`--cpfg-view`; README, "Coming from cpfg: turtle queries"). The
//! expected values are worked out by hand below, with cpfg's turtle
//! (`interpret.c`): position 0, heading H = (0,1,0), left L = (-1,0,0),
//! up U = (0,0,-1); `+` turns H towards L (H' = cH + sL, L' = cL - sH).
//! tests/cpfg_random.rs checks random systems against the independent
//! reference tests/tools/cpfg_ref.py.

mod common;

use common::{lsgen, run, tempdir, write, ROOT};
use std::path::{Path, PathBuf};

/// A `.l` file and its view file in a fresh directory; lsgen's output for
/// `args` (then `--cpfg-view plant.v plant.l`).
fn derive(l: &str, v: &str, args: &[&str]) -> common::Run {
    let dir = tempdir();
    let view = write(dir.path(), "plant.v", v);
    let file = write(dir.path(), "plant.l", l);
    run(lsgen().args(args).arg("--cpfg-view").arg(&view).arg(&file))
}

fn ok(l: &str, v: &str, args: &[&str]) -> String {
    derive(l, v, args).ok()
}

fn system(n: u32, axiom: &str, productions: &str) -> String {
    format!("Lsystem: 1\nderivation length: {n}\nAxiom: {axiom}\n{productions}\nendlsystem\n")
}

/// F(2) goes to (0,2,0); +(90) turns H to (-1, cos 90°, 0), cos 90° being
/// 6.12323e-17 in doubles (as cpfg prints it, a float of it); F(1) goes to
/// (-1,2,0). The axiom's queries are filled before step 1 and the final
/// string's before it is printed, also with `-n 0`; a query's values
/// replace what the module held, past the third parameter nothing.
#[test]
fn position_and_heading_after_moves_and_turns() {
    let l = system(
        2,
        "F(2)+(90)F(1)?P(7,7,7,7)A",
        "A --> F(1)?H(0,0,0)?L(0)?U(5,5)A",
    );
    let v = "angle increment: 90\n";
    assert_eq!(ok(&l, v, &["-n", "0"]), "F(2)+(90)F(1)?P(-1,2,0,7)A\n");
    // Step 1's F(1) goes on along H: to (-2,2,0). L' = cL - sH = (-c,-1,0);
    // U is not turned.
    assert_eq!(
        ok(&l, v, &["-n", "1"]),
        "F(2)+(90)F(1)?P(-1,2,0,7)F(1)?H(-1,6.12323e-17,0)?L(-6.12323e-17)?U(0,0)A\n"
    );
}

/// A production reads a query through its right context: the apex grows
/// while it is below y = 3. Before step 1 the apex is at y = 0 (A ?P), so
/// it grows: F(1) A ?P; before step 2 at y = 1, step 3 at y = 2: grows;
/// before step 4 at y = 3: stops (B). Steps 5 and 6 change nothing.
#[test]
fn a_condition_reads_the_turtle_through_a_right_context() {
    let l = system(
        6,
        "A?P(0,0)",
        "A > ?P(x,y) : y < 3 --> F(1)A\nA > ?P(x,y) : y >= 3 --> B",
    );
    assert_eq!(ok(&l, "angle factor: 8\n", &[]), "F(1)F(1)F(1)B?P(0,3)\n");
}

/// A predecessor of two modules, `?` and the query: the query rewritten
/// where the turtle is left of the axis (x < 0). `-(90)` turns H towards
/// -L, that is to +x; `+(90)` to -x.
#[test]
fn a_query_as_a_predecessor() {
    let l = system(
        1,
        "[+(90)F(1)?P(0,0)][-(90)F(1)?P(0,0)]",
        "?P(x,y) : x < 0 --> L?P(x,y)",
    );
    assert_eq!(
        ok(&l, "angle increment: 45\n", &[]),
        "[+(90)F(1)L?P(-1,6.12323e-17)][-(90)F(1)?P(1,6.12323e-17)]\n"
    );
}

/// cpfg's tropism: after each move, H turns towards U by the angle whose
/// sine is e (T·U), then towards L by the angle whose sine is e (T·L).
/// T = (1,0,0), e = 0.5: after the first F, T·U = 0 and T·L = -1, so
/// H' = cos(30°) H - 0.5 L = (0.5, 0.866025, 0); the second F goes to
/// (0.5, 1 + 0.866025, 0). `_(0)` then stops the bending: the third F
/// goes straight on.
#[test]
fn the_tropism_bends_after_moves() {
    let l = system(1, "F?H(0,0,0)F?P(0,0,0)_(0)F?H(0,0,0)", "");
    let v = "tropism direction: 1,0,0\ninitial elasticity: 0.5\n";
    let out = ok(&l, v, &["-n", "0"]);
    // The second F bends again: H after it is rotated once more.
    let want_start = "F?H(0.5,0.866025,0)F?P(0.5,1.86603,0)_(0)F?H(";
    assert!(out.starts_with(want_start), "{out}");
    // Without elasticity: no bend.
    let out = ok(&l, "tropism direction: 1,0,0\n", &["-n", "0"]);
    assert_eq!(out, "F?H(0,1,0)F?P(0,2,0)_(0)F?H(0,1,0)\n");
}

/// `initial scale:` multiplies the lengths; `@M` puts the turtle at a
/// point (z = 0 with two parameters); `|` turns it around.
#[test]
fn scale_move_to_and_turn_around() {
    let l = system(1, "F(2)?P(0,0,0)@M(5,6)F?P(0,0,0)|F?P(0,0,0)?H(0,0,0)", "");
    assert_eq!(
        ok(&l, "initial scale: 3\n", &["-n", "0"]),
        "F(2)?P(0,6,0)@M(5,6)F?P(5,9,0)|F?P(5,6,0)?H(-0,-1,0)\n"
    );
}

/// cpfg's generalized cylinders (`@Gs`, `@Gc(n)`, `@Ge(n)`, `@Gt`,
/// `@Gr`) set the spline's state, never the turtle's place: the `G` after
/// `@` is no move.
#[test]
fn generalized_cylinders_do_not_move_the_turtle() {
    let l = system(0, "@GsF(2)@Gc(3)@Gt(1,2)F?P(0,0)@Ge(3)", "");
    assert_eq!(ok(&l, "", &[]), "@GsF(2)@Gc(3)@Gt(1,2)F?P(0,3)@Ge(3)\n");
}

/// `interpretation past %: off`: the turtle skips the rest of a branch
/// after `%`, so a query there keeps its values (`on`, cpfg's default: it
/// is filled). The `]` ends the skip: the query after it is filled.
#[test]
fn interpretation_past_a_cut() {
    let l = system(1, "[F%F?P(9,9)]F(4)?P(9,9)", "");
    assert_eq!(
        ok(&l, "interpretation past %: off\n", &["-n", "0"]),
        "[F%F?P(9,9)]F(4)?P(0,4)\n"
    );
    assert_eq!(
        ok(&l, "interpretation past %: on\n", &["-n", "0"]),
        "[F%F?P(0,2)]F(4)?P(0,4)\n"
    );
}

/// A homomorphism that cannot move the turtle (its moves inside its own
/// branches, a predecessor that does not move it): cpfg's turtle goes
/// through it as if it were not there, and the printed string has it
/// applied. Each A adds F(1) before the apex: the query after the apex
/// is at y = steps + 1 (the axiom's F(1)), whatever A draws.
#[test]
fn a_homomorphism_that_cannot_move_the_turtle() {
    let l = "Lsystem: 1\nderivation length: 2\nAxiom: F(1)A?P(0,0)\n\
             A > ?P(x,y) : y < 10 --> F(1)A\nhomomorphism\nmaximum depth: 2\n\
             A --> [F(5)+F(3)B];(2)\nB --> [&&F@R(1,0,0)~l]\nendlsystem\n";
    assert_eq!(
        ok(l, "angle factor: 4\n", &[]),
        "F(1)F(1)F(1)[F(5)+F(3)[&&F@R(1,0,0)~l]];(2)?P(0,3)\n"
    );
}

/// A homomorphism that moves the turtle: cpfg's turtle reads the string
/// through it, and so does lsgen's. `I(l)` is drawn as `F(l)`, `A` as
/// `-(90)`. The axiom: I(1) moves to y = 1; A turns H towards -L, to
/// (1, cos 90°, 0); so ?P = (0,1) and ?H = (1, 6.12323e-17, 0). A grows
/// (adds I(2)) while the query after it is below y = 4: before step 1 at
/// y = 1, before step 2 at 3, before step 3 at 5, where it stops (B, which
/// the homomorphism leaves). The string is printed through the
/// homomorphism, and without it with `--no-homomorphism`: its queries are
/// filled through it all the same.
#[test]
fn a_homomorphism_that_moves_the_turtle() {
    let l = "Lsystem: 1\nderivation length: 4\nAxiom: I(1)A?P(0,0)?H(0,0,0)\n\
             A > ?P(x,y) : y < 4 --> I(2)A\nA > ?P(x,y) : y >= 4 --> B\n\
             homomorphism\nI(l) --> F(l)\nA --> -(90)\nendlsystem\n";
    let v = "angle factor: 8\n";
    assert_eq!(
        ok(l, v, &["-n", "0"]),
        "F(1)-(90)?P(0,1)?H(1,6.12323e-17,0)\n"
    );
    assert_eq!(ok(l, v, &[]), "F(1)F(2)F(2)B?P(0,5)?H(0,1,0)\n");
    assert_eq!(
        ok(l, v, &["--no-homomorphism"]),
        "I(1)I(2)I(2)B?P(0,5)?H(0,1,0)\n"
    );
    // Step by step: each string's queries read the moves its
    // homomorphism makes (y = 3 after step 1, 5 after step 2).
    assert_eq!(
        ok(l, v, &["-n", "1", "--no-homomorphism"]),
        "I(1)I(2)A?P(0,3)?H(1,6.12323e-17,0)\n"
    );
    // `maximum depth: 2`: I's successor is rewritten once more (J(l) to
    // two moves of l), as cpfg's turtle reads it; frames and threads
    // agree.
    let deep = "Lsystem: 1\nderivation length: 2\nAxiom: I(1)A?P(0,0)\nA --> I(1)A\n\
                homomorphism\nmaximum depth: 2\nI(l) --> J(l)+(0)\nJ(l) --> F(l)F(l)\nendlsystem\n";
    let want = "F(1)F(1)+(0)F(1)F(1)+(0)F(1)F(1)+(0)A?P(0,6)\n";
    for j in ["1", "2", "8"] {
        assert_eq!(ok(deep, v, &["-j", j]), want, "-j {j}");
    }
    let dir = tempdir();
    let view = write(dir.path(), "plant.v", v);
    let file = write(dir.path(), "plant.l", deep);
    let r = run(lsgen()
        .args(["--frames", "0..2", "-o"])
        .arg(dir.path().join("frame{n}.txt"))
        .arg("--cpfg-view")
        .arg(&view)
        .arg(&file));
    assert_eq!(r.code(), Some(0), "{}", r.stderr);
    for (k, y) in [(0, 2), (1, 4), (2, 6)] {
        let frame = std::fs::read_to_string(dir.path().join(format!("frame{k}.txt"))).unwrap();
        assert!(
            frame.ends_with(&format!("A?P(0,{y})\n")),
            "frame {k}: {frame}"
        );
    }
}

/// cpfg fills the string a step rewrites before that step (its
/// `StartEach:`), after the step before ended (its `EndEach:`, and
/// `End:` for the saved string): a moving homomorphism's condition reads
/// the globals those blocks left. Here `t` is the number of `EndEach:`
/// run so far (5 after `End:`), and `I` moves the turtle only when `t`
/// is 1 (or 5 with `End:`): with `box:`, the string of `-n 2` shows the
/// fill before step 2, `t` = 1; of `-n 3`, before step 3, `t` = 2. Hand
/// computed (as cpfg_ref.py gives them); frames agree.
#[test]
fn a_moving_homomorphism_reads_the_globals_after_end_each() {
    let l = "Lsystem: 1\nderivation length: 9\nStart: {t = 0;}\nEndEach: {t = t + 1;}\n\
             Axiom: I(1)?P(0,0,0)\nhomomorphism\nI(l) : t == 1 --> F(l)\nendlsystem\n";
    let boxed = "angle increment: 90\nbox: x: -1,1 y: -1,1 z: -1,1\n";
    let args = ["--no-homomorphism", "-n"];
    for (n, y) in [("1", 0), ("2", 1), ("3", 0)] {
        let want = format!("I(1)?P(0,{y},0)\n");
        assert_eq!(ok(l, boxed, &[&args[..], &[n]].concat()), want, "-n {n}");
    }
    // Without `box:` the saved string is filled after the last step's
    // `EndEach:` and `End:`.
    let v = "angle increment: 90\n";
    let end = l
        .replace(
            "derivation length: 9",
            "derivation length: 1\nEnd: {t = 5;}",
        )
        .replace("t == 1", "t == 5");
    assert_eq!(ok(&end, v, &["--no-homomorphism"]), "I(1)?P(0,1,0)\n");
    assert_eq!(ok(&end, v, &[]), "F(1)?P(0,1,0)\n");
    // (`End:` runs after the last frame only: README, `--frames`.)
    for (l, v, last) in [(l, boxed, 3), (&end[..], v, 1)] {
        let dir = tempdir();
        let view = write(dir.path(), "plant.v", v);
        let file = write(dir.path(), "plant.l", l);
        let r = run(lsgen()
            .args(["--frames", &format!("0..{last}"), "--no-homomorphism"])
            .arg("--cpfg-view")
            .arg(&view)
            .arg(&file));
        let want: String = (0..=last)
            .map(|k| ok(l, v, &["--no-homomorphism", "-n", &k.to_string()]))
            .collect();
        assert_eq!(r.ok(), want, "{v}");
    }
}

/// cpfg's movements (the view's `tropism:` and `torque:` lines,
/// `movements.c`): before each move, all tropisms together turn H about
/// H × V by half |H × V| (V the elasticity times T), then U follows H's
/// turn since the last move (`adjust_up_and_left`), L = H × U; a torque
/// turns U about U × D by half |U × D| (D: the twist's direction,
/// projected across H, times its elasticity). cpfg turns a vector v by a
/// quaternion q as q⁻¹ v q, the opposite way of q v q⁻¹: the tropism's
/// half angle is negative, so H turns towards T; the torque's is not, so
/// U turns away from D. s = sin 0.5 = 0.479426, c = cos 0.5 = 0.877583.
#[test]
fn cpfg_movements_turn_the_turtle_before_each_move() {
    let check = |axiom: &str, v: &str, want: &str| {
        let l = system(0, axiom, "");
        assert_eq!(ok(&l, v, &["-n", "0"]), format!("{want}\n"), "{v}");
    };
    // T = (1,0,0), E = 0.5: H × V = (0,0,-0.5), H turns by 0.5 towards
    // +x: (s, c, 0); U, turned about H × H_prev = (0,0,s), stays; L =
    // (-c, s, 0). Then F moves along the new H.
    check(
        "F?H(0,0,0)?L(0,0,0)?U(0,0,0)?P(0,0,0)",
        "tropism: T: 1,0,0 E: 0.5\n",
        "F?H(0.479426,0.877583,0)?L(-0.877583,0.479426,0)?U(0,0,-1)?P(0.479426,0.877583,0)",
    );
    // `@Ts(1,0.5)` sets the first movement's elasticity in the branch;
    // its `]` gives the view's (0) back: the F after it goes straight.
    check(
        "[@Ts(1,0.5)F?H(0,0,0)]F?H(0,0,0)",
        "tropism: T: 1,0,0\n",
        "[@Ts(1,0.5)F?H(0.479426,0.877583,0)]F?H(0,1,0)",
    );
    // `A:90` (plagiotropism) along H: H × T = 0, so cpfg turns about L:
    // V = 0.5 · T × L = (0,0,0.5) (plus cos 90° · 0.5 · T, about 3e-17 in
    // y), H × V = (0.5,0,0): H turns to (0, c, s), U about (-s,0,0) to
    // (0, s, -c), L = (-1, 0, 0).
    check(
        "F?H(0,0,0)?L(0,0,0)?U(0,0,0)",
        "tropism: T: 0,1,0 A:90 E: 0.5\n",
        "F?H(0,0.877583,0.479426)?L(-1,0,0)?U(0,0.479426,-0.877583)",
    );
    // A torque of T = (1,0,0), E = 0.2: D = (H × T) × H · 0.2 =
    // (0.2,0,0), U × D = (0,-0.2,0): U turns by 0.2 about +y (away from
    // D), to (-sin 0.2, 0, -cos 0.2); H stays.
    check(
        "F?H(0,0,0)?L(0,0,0)?U(0,0,0)",
        "torque: T: 1,0,0 E: 0.2\n",
        "F?H(0,1,0)?L(-0.980067,0,0.198669)?U(-0.198669,0,-0.980067)",
    );
    // `@Ti(1)` adds the increment (`S:`), `@Td(1)` takes it away again;
    // `@Ti` without a parameter does nothing (cpfg); `f` turns as `F`.
    check(
        "@Ti(1)@Ti@Td(1)@Ti(1)f?H(0,0,0)",
        "tropism: T: 1,0,0 S: 0.5\n",
        "@Ti(1)@Ti@Td(1)@Ti(1)f?H(0.479426,0.877583,0)",
    );
}

/// cpfg's `@Tp` and `@Tf` (blackbox.c) need no movement line: without a
/// parameter the index is 0 and unchecked, and `@Tp` turns U from the last
/// `F`'s as H turned since (`adjust_up_and_left`). By hand: after `F`,
/// `/(90)` rolls U into the x axis and `+(30)` turns H to (0, c30, -s30)
/// about it; `@Tp` turns the `F`'s U = (0,0,-1) as H turned, about x by
/// 30 degrees: (0, -0.5, -0.866025), L = H × U = (-1, 0, 0) (the values
/// as the reference, tests/tools/cpfg_ref.py, prints them). With a number
/// past the movements (none here) cpfg does nothing.
#[test]
fn at_tp_and_at_tf_without_movement_lines() {
    let l = system(0, "F/(90)+(30)@Tp?U(0,0,0)?L(0,0,0)", "");
    assert_eq!(
        ok(&l, "angle increment: 90\n", &["-n", "0"]),
        "F/(90)+(30)@Tp?U(8.20358e-18,-0.5,-0.866025)?L(-1,-3.06162e-17,8.20358e-18)\n"
    );
    // `@Tf` makes the frame after the turns the last move's: `@Tp` then
    // changes nothing.
    let l = system(0, "F/(90)+(30)@Tf@Tp?U(0,0,0)", "");
    assert_eq!(
        ok(&l, "angle increment: 90\n", &["-n", "0"]),
        "F/(90)+(30)@Tf@Tp?U(1,0,-6.12323e-17)\n"
    );
    let l = system(0, "F/(90)+(30)@Tp(1)?U(0,0,0)", "");
    assert_eq!(
        ok(&l, "angle increment: 90\n", &["-n", "0"]),
        "F/(90)+(30)@Tp(1)?U(1,0,-6.12323e-17)\n"
    );
}

/// cpfg reads a movement line's rest with `fgets(input_line, 255, fp)`:
/// 254 bytes, its newline counted; past them it cuts the line (here the
/// `E: 0.5` after 260 blanks would not be read: the tropism would not
/// turn the turtle) and reads the rest as a label. Refused, as the
/// reference refuses it; 253 bytes and the newline are read.
#[test]
fn a_movement_line_longer_than_cpfg_reads_is_refused() {
    let l = system(0, "F?H(0,0,0)", "");
    let long = format!("tropism: T: 1,0,0{}E: 0.5\n", " ".repeat(260));
    let r = derive(&l, &long, &["-n", "0"]);
    assert_eq!(r.code(), Some(1), "{}", r.stderr);
    assert!(
        r.stderr
            .contains("a `tropism:` line that is longer than the 254 bytes cpfg reads"),
        "{}",
        r.stderr
    );
    // " T: 1,0,0" (9 bytes), blanks, "E: 0.5" (6), the newline: 254.
    let fits = format!("tropism: T: 1,0,0{}E: 0.5\n", " ".repeat(238));
    assert_eq!(ok(&l, &fits, &["-n", "0"]), "F?H(0.479426,0.877583,0)\n");
}

/// A movement line cpfg ignores (a zero direction) is a warning here too,
/// as in lsgen-turtle, and moves nothing: the heading stays (0,1,0). A
/// file refused for another reason says only its error.
#[test]
fn an_ignored_movement_line_is_a_warning() {
    let l = system(0, "F?H(0,0,0)", "");
    let v = "tropism: T: 0,0,0 E: 1\n";
    let r = derive(&l, v, &["-n", "0"]);
    assert_eq!((r.code(), &r.stdout[..]), (Some(0), &b"F?H(0,1,0)\n"[..]));
    assert!(
        r.stderr.contains(
            "plant.v:1:1: warning: `tropism:` ignored: cpfg ignores a movement with a direction of length 0"
        ),
        "{}",
        r.stderr
    );
    let refused = system(0, "F?H(0,0,0)?E(1)", "");
    let r = derive(&refused, v, &["-n", "0"]);
    assert_eq!(r.code(), Some(1), "{}", r.stderr);
    assert!(!r.stderr.contains("warning"), "{}", r.stderr);
}

/// `--max-length` also bounds the homomorphism's image the queries read
/// (a temporary file), and its error names that image, not the
/// homomorphism pass, which `--no-homomorphism` does not run. After step
/// 1 the string is I(1)I(1)A?P(0,0), 5 modules (`?P` counts as two, as
/// `-v` says), and its image 6 + 6 + 3 = 15 modules.
#[test]
fn max_length_names_the_image_the_queries_read() {
    let l = "Lsystem: 1\nderivation length: 2\nAxiom: I(1)A?P(0,0)\nA --> I(1)A\n\
             homomorphism\nI(l) --> F(l)F(l)F(l)F(l)F(l)F(l)\nendlsystem\n";
    let v = "angle factor: 8\n";
    for args in [&[][..], &["--no-homomorphism"]] {
        let r = derive(l, v, &[args, &["--max-length", "12"]].concat());
        let e = r.fails(1);
        assert!(
            e.contains(
                "lsgen: error: the string grew past --max-length (12 modules) in the \
                 homomorphism's image of the string after step 1 (read by the turtle queries)"
            ),
            "{e}"
        );
    }
    // After step 2 the image is 18 + 3 = 21 modules: 21 fits. I(1)'s
    // image moves 6 times, three times: the query is at y = 18.
    let r = derive(l, v, &["--no-homomorphism", "--max-length", "21"]);
    assert_eq!(r.ok(), "I(1)I(1)I(1)A?P(0,18)\n");
}

/// cpfg fills the saved string's queries when it works out the view
/// volume around it, which a view file's `box:` turns off; then only
/// `environment display: before` (a fill after each step) does. The
/// string a step rewrites is filled either way.
#[test]
fn the_last_string_with_a_box() {
    let l = system(2, "A", "A --> F(1)?P(9,9)A");
    let boxed = "box: x: -1,1 y: -1,1 z: -1,1\n";
    // Step 2 rewrote a filled string (the first ?P is at y = 1); the last
    // ?P is the successor's.
    assert_eq!(ok(&l, boxed, &[]), "F(1)?P(0,1)F(1)?P(9,9)A\n");
    assert_eq!(ok(&l, boxed, &["-n", "1"]), "F(1)?P(9,9)A\n");
    let before = format!("{boxed}environment display: before\n");
    assert_eq!(ok(&l, &before, &[]), "F(1)?P(0,1)F(1)?P(0,2)A\n");
    assert_eq!(ok(&l, "", &[]), "F(1)?P(0,1)F(1)?P(0,2)A\n");
    // Frames: each as `-n k` prints it.
    for v in [boxed, ""] {
        let dir = tempdir();
        let view = write(dir.path(), "plant.v", v);
        let file = write(dir.path(), "plant.l", &l);
        let r = run(lsgen()
            .args(["--frames", "0..2", "--cpfg-view"])
            .arg(&view)
            .arg(&file));
        let want: String = (0..=2)
            .map(|k| ok(&l, v, &["-n", &k.to_string()]))
            .collect();
        assert_eq!(r.ok(), want, "{v}");
    }
}

/// The same string at any thread count and with `--frames`.
#[test]
fn threads_and_frames_agree() {
    let l = system(
        5,
        "A?P(0,0)",
        "A > ?P(x,y) : y < 3 --> F(1)[+A?P(0,0)]A\nA > ?P(x,y) : y >= 3 --> B",
    );
    let v = "angle factor: 8\n";
    let one = ok(&l, v, &["-j", "1"]);
    assert_eq!(ok(&l, v, &["-j", "2"]), one);
    assert_eq!(ok(&l, v, &["-j", "8"]), one);
    let dir = tempdir();
    let view = write(dir.path(), "plant.v", v);
    let file = write(dir.path(), "plant.l", &l);
    let r = run(lsgen()
        .args(["--frames", "0..5", "-o"])
        .arg(dir.path().join("frame{n}.txt"))
        .arg("--cpfg-view")
        .arg(&view)
        .arg(&file));
    assert_eq!(r.code(), Some(0), "{}", r.stderr);
    for k in 0..=5 {
        let frame = std::fs::read_to_string(dir.path().join(format!("frame{k}.txt"))).unwrap();
        assert_eq!(frame, ok(&l, v, &["-n", &k.to_string()]), "frame {k}");
    }
    assert!(one.contains("?P(0,3)"), "{one}");
}

/// Errors: a query without the view file, with a homomorphism, with what
/// lsgen's query turtle does not follow, with cpfg's movements in the
/// view file.
#[test]
fn refused() {
    let dir = tempdir();
    let v = write(dir.path(), "plant.v", "angle factor: 8\n");
    let check = |l: &str, view: Option<&Path>, want: &str| {
        let file = write(dir.path(), "plant.l", l);
        let mut cmd = lsgen();
        if let Some(view) = view {
            cmd.arg("--cpfg-view").arg(view);
        }
        let r = run(cmd.arg(&file));
        let e = r.fails(1).to_string();
        assert!(e.contains(want), "{e}");
    };
    let l = system(1, "A", "A --> F?P(0,0)");
    check(
        &l,
        None,
        "plant.l:4:8: error: a query of the turtle (`?P`, `?H`, `?L`, `?U`) needs cpfg's view file",
    );
    // A homomorphism production the query turtle cannot follow as cpfg's
    // does: each way, located at what it cannot follow.
    for (production, at, what) in [
        (
            "A --> F%",
            "5:8",
            "with `%` outside a branch of its successor",
        ),
        // (cpfg reads a query's module past the homomorphism.)
        (
            "P(x,y) --> F",
            "5:1",
            "with a predecessor `P`, which a `?` or an `@` reads",
        ),
        // (cpfg reads it in the string as it fills it; lsgen's turtle an
        // image made before the fill.)
        (
            "P(x,y) < A --> F",
            "5:1",
            "with a left context `P`, which a query fills",
        ),
        ("A --> [F", "5:1", "with a `[` without its `]`"),
        ("A --> ]", "5:7", "with a `]` without its `[`"),
        ("A --> B?P(1)", "5:8", "with a `?` in its successor"),
        ("A --> B(ran(1))", "5:9", "with a random draw"),
        ("A : {x = 1;} 1 --> B", "5:1", "with a block"),
    ] {
        let hom = format!(
            "Lsystem: 1\nAxiom: A?P(0,0)\nA --> FA\nhomomorphism\n{production}\nendlsystem\n"
        );
        check(
            &hom,
            Some(&v),
            &format!("plant.l:{at}: error: a homomorphism production {what}"),
        );
    }
    // What the query turtle does not follow, in the file's own lists
    // (`n`, axiom, productions; with the view `v`).
    for (n, axiom, productions, want) in [
        (
            1,
            "A?P(0,0)",
            "A --> ~lA",
            "error: `~` (a surface) in a system with turtle queries",
        ),
        (
            1,
            "A?P(0,0)",
            "A --> @R(1,0,0)A",
            "plant.l:4:7: error: `@R` in a system with turtle queries",
        ),
        (
            1,
            "A?P(0,0)",
            "A --> @GxA",
            "plant.l:4:7: error: `@Gx` in a system with turtle queries",
        ),
        // (In every list but a homomorphism's successor, whose branches
        // give the turtle back: there `[@R(1,0,0)F]` is accepted.)
        (
            1,
            "A?P(0,0)",
            "A > ?P(x,y) --> [@R(1,0,0)F]A",
            "plant.l:4:18: error: `@R` in a system with turtle queries",
        ),
        (1, "A?P(0,0)", "A --> A@", "`@` at the end of a successor"),
        // (cpfg's `@G(x)` reads no subfunction: its turtle goes back to
        // read `G(x)` as a move of its own, `blackbox.c`.)
        (
            1,
            "A?P(0,0)",
            "A --> @G(1)sA",
            "plant.l:4:7: error: `@G` with parameters in a system with turtle queries",
        ),
        // cpfg's older position query `s(x,y)`.
        (1, "A?P(0,0)", "A --> s(1,2)A", "`s` with 2 or 3 parameters"),
        // A production that rewrites a query module away from its `?`.
        (
            2,
            "A?P(0,0)",
            "P(x,y) --> B",
            "`?` followed by `B`, not by the `P`, `H`, `L` or `U` it fills",
        ),
        (2, "A?P(0,0)", "P(x,y) -->", "`?` at the end of the string"),
    ] {
        check(&system(n, axiom, productions), Some(&v), want);
    }
    // ... and in a homomorphism's successors where it moves the turtle,
    // branches too (the turtle reads them): `@R` outside a branch, `~`
    // in one beside a move.
    for (production, want) in [
        (
            "A --> @R(1,0,0)",
            "plant.l:5:7: error: `@R` in a system with turtle queries",
        ),
        (
            "A --> F[~l]",
            "plant.l:5:9: error: `~` (a surface) in a system with turtle queries",
        ),
    ] {
        let hom = format!(
            "Lsystem: 1\nAxiom: A?P(0,0)\nA --> FA\nhomomorphism\n{production}\nendlsystem\n"
        );
        check(&hom, Some(&v), want);
    }
    // View files the query turtle refuses (name, text, axiom, message):
    // ten of cpfg's movements; a bend by a sine past 1 (at run time, not NaN); an
    // argument cpfg cannot read (vlab has `angle increment: ?` in an
    // exercise: cpfg warns), where the turtle needs it.
    for (name, text, axiom, want) in [
        (
            "moving.v",
            "angle factor: 8\ntropism: T: 1,0,0\ntropism: T: 0 0 0\n\
             torque: T: 1,0,0\ntropism: T: 1,0,0\ntorque: T: 1,0,0\n\
             tropism: T: 1,0,0\ntorque: T: 1,0,0\ntropism: T: 1,0,0\n\
             torque: T: 1,0,0\ntropism: T: 1,0,0\ntorque: T: 1,0,0\n",
            "A?P(0,0)",
            // (Ten movements, the line cpfg ignores not counted: the
            // tenth is on line 12.)
            "moving.v:12:1: error: a `torque:` line that is a tenth movement",
        ),
        (
            "bent.v",
            "tropism direction: 1,0,0\ninitial elasticity: 2\n",
            "F?P(0,0)",
            "cpfg's tropism bends the turtle by a sine past 1",
        ),
        // An elasticity near the largest number: cpfg's movement sums
        // overflow and the heading collapses (`?H(0,0,0)` was filled with
        // 0,0,0).
        (
            "big.v",
            "tropism: T: 1,0,0 A: 30 E: 1e308\n",
            "F?H(0,0,0)",
            "cpfg's tropism or torque (the view file's movements) overflows",
        ),
        (
            "odd.v",
            "angle increment: ?\n",
            "A?P(0,0)",
            "odd.v:1:18: error: `angle increment:` takes a number",
        ),
        // An angle past the largest float (cpfg keeps it as one): refused
        // when the file is loaded, not when a turn first reads it.
        (
            "huge.v",
            "angle increment: 1e40\n",
            "A?P(0,0)",
            "huge.v:1:18: error: `angle increment:` gives an angle past the largest float",
        ),
        (
            "tiny.v",
            "angle increment: 1e40\nangle factor: 1e-40\n",
            "A?P(0,0)",
            "tiny.v:2:15: error: `angle factor:` gives an angle past the largest float",
        ),
    ] {
        let view = write(dir.path(), name, text);
        check(&system(1, axiom, "A --> FA"), Some(&view), want);
    }
    // The odd view derives a file without queries.
    let odd = dir.path().join("odd.v");
    let file = write(dir.path(), "plant.l", system(1, "A", "A --> FA"));
    let r = run(lsgen().arg("--cpfg-view").arg(&odd).arg(&file));
    assert_eq!(r.ok(), "FA\n");
    // Branches nested deeper than the turtle keeps (2^20): an error, not
    // memory without bound.
    let deep = 1 << 20;
    let axiom = format!("{}F?P(0,0){}", "[".repeat(deep + 1), "]".repeat(deep + 1));
    let l = system(0, &axiom, "");
    check(&l, Some(&v), "branches nested deeper than 1048576");
    let axiom = format!("{}F?P(0,0){}", "[".repeat(deep), "]".repeat(deep));
    let file = write(dir.path(), "plant.l", system(0, &axiom, ""));
    let r = run(lsgen().arg("--cpfg-view").arg(&v).arg(&file));
    assert!(r.ok().contains("F?P(0,1)]"));
    // An axiom given apart (`--axiom`) is not checked when the file is
    // loaded: what the turtle does not follow stops it there.
    let l = system(0, "A?P(0,0)", "");
    let file = write(dir.path(), "plant.l", &l);
    for (axiom, want) in [
        ("F~lF?P(0,0)", "`~` (a surface) moves cpfg's turtle"),
        ("F@R(1,0,0)?P(0,0)", "an `@` module moves cpfg's turtle"),
        ("F?P(0,0)@", "an `@` at the end of the string"),
    ] {
        let r = axiom_apart(dir.path(), &v, &file, axiom);
        let e = r.fails(1).to_string();
        assert!(e.contains(want), "{e}");
        assert!(e.contains("as the turtle interprets the axiom"), "{e}");
    }
    // A module read past the homomorphism (after `?` or `@`) that it
    // rewrites, in an axiom given apart: refused where the turtle reads it.
    let l = "Lsystem: 1\nAxiom: A?H(0,0)\nhomomorphism\nA --> F\nP(x,y) --> F\nv --> M(1,2)\nendlsystem\n";
    let file = write(dir.path(), "plant.l", l);
    for (axiom, sym) in [("AF?P(0,0)", 'P'), ("A@vF?H(0,0)", 'v')] {
        let r = axiom_apart(dir.path(), &v, &file, axiom);
        let e = r.fails(1).to_string();
        let want = format!("`{sym}`, read by a `?` or an `@`, has a homomorphism production");
        assert!(e.contains(&want), "{axiom}: {e}");
    }
    // Other `?` are still refused, with or without the view.
    let l = system(1, "A", "A --> F?E(1)");
    check(&l, Some(&v), "`?E`");
}

/// The example examples/cpfg/clipped.l (a shrub clipped to a ball by its
/// queries), as README's pipe derives it, is the reference's string
/// (tests/expected/cpfg/examples/, from tests/tools/cpfg_ref.py), on one
/// thread and on several.
#[test]
fn the_clipped_example_is_the_references() {
    let want = std::fs::read_to_string(
        Path::new(ROOT).join("tests/expected/cpfg/examples/clipped.n22.txt"),
    )
    .unwrap();
    for j in ["1", "2", "8"] {
        let r = run(lsgen().current_dir(ROOT).args([
            "examples/cpfg/clipped.l",
            "--cpfg-view",
            "examples/cpfg/clipped.v",
            "-j",
            j,
        ]));
        assert_eq!(r.ok(), want, "-j {j}");
    }
    // The flowers are where the ball clips the shoots: dozens of them.
    assert!(want.matches("@O(0.4)").count() > 50);
}

/// An axiom given apart (`--axiom`) is checked as the turtle meets it:
/// `?` with parameters is cpfg's sub-L-system call (`?(id,scale)`, which
/// scales the turtle), refused as in the file's own strings, not passed
/// over as a module that leaves the turtle still.
#[test]
fn a_sub_lsystem_call_in_an_axiom_given_apart() {
    let dir = tempdir();
    let v = write(dir.path(), "plant.v", "angle factor: 8\n");
    let l = write(dir.path(), "plant.l", system(1, "?P(0,0)", "A --> B"));
    for axiom in ["F?(1)P(0,0)\n", "F?(1,2)F?P(0,0)\n"] {
        let r = axiom_apart(dir.path(), &v, &l, axiom);
        let e = r.fails(1).to_string();
        assert!(
            e.contains("lsgen: error: `?` with parameters (a sub-L-system call)"),
            "{axiom}: {e}"
        );
    }
}

/// A query module rewritten into `Q` or `E`: cpfg does not skip them
/// with a warning (as any other module after `?`) but fills a quaternion
/// (`?Q`) or talks to its environment (`?E`); the message says so.
#[test]
fn a_query_rewritten_into_a_quaternion_query() {
    for (to, want) in [
        ("Q", "error: `?Q` (cpfg's quaternion query) is not filled by lsgen's query turtle, as the turtle interprets the string of step 1"),
        ("E", "error: `?E` (cpfg's communication with an environment program) is not filled by lsgen's query turtle, as the turtle interprets the string of step 1"),
        ("X", "error: `?` followed by `X`, not by the `P`, `H`, `L` or `U` it fills (a production rewrote it; cpfg skips the `X` with a warning)"),
    ] {
        let l = system(1, "F?P(0,0)", &format!("P(x,y) --> {to}(x,y)"));
        let r = derive(&l, "angle factor: 8\n", &[]);
        let e = r.fails(1).to_string();
        assert!(e.contains(want), "{to}: {e}");
    }
}

/// With `interpretation past %: off`, cpfg's turtle skips the rest of a
/// branch after `%` but stops at a `$` or at a `%` with parameters
/// (`SkipCutPart`, generate.c), and goes on from there: in an axiom given
/// apart (the file's own strings cannot hold them) they are refused, not
/// skipped with the rest.
#[test]
fn what_stops_the_skip_after_a_cut() {
    let dir = tempdir();
    let v = cut_off_view(dir.path());
    let l = write(dir.path(), "plant.l", system(1, "?P(0,0)", "A --> B"));
    for (axiom, want) in [
        ("F[%F$F?P(0,0)]?P(0,0)\n", "`$` (the end of a sub-L-system)"),
        ("F[%F%(1)F?P(0,0)]?P(0,0)\n", "`%` with parameters"),
    ] {
        let r = axiom_apart(dir.path(), &v, &l, axiom);
        let e = r.fails(1).to_string();
        assert!(e.contains(&format!("lsgen: error: {want}")), "{axiom}: {e}");
    }
    // (What else the skipped part holds is skipped, also an `@` command
    // or a `?` cut short by the end of the string.)
    let r = axiom_apart(dir.path(), &v, &l, "F[%F~l@RF?P(0,0)]?P(0,0)\n");
    assert_eq!(r.ok(), "F[%F~l@RF?P(0,0)]?P(0,1)\n");
    for tail in ["?", "@G", "@T", "F@P", "@"] {
        let r = axiom_apart(dir.path(), &v, &l, &format!("F?P(0,0)%{tail}\n"));
        assert_eq!(r.ok(), format!("F?P(0,1)%{tail}\n"), "{tail}");
    }
}

/// The turtle reads a string through a moving homomorphism and takes each
/// query module from the string itself: both find the queries by one rule,
/// also in a branch skipped after `%`, where `@?P` is an `@` command whose
/// function is `?`, not a query (the turtle took it for one there, and the
/// query after the branch found none left in the string).
#[test]
fn a_skipped_at_command_keeps_the_queries_in_step() {
    let dir = tempdir();
    let v = cut_off_view(dir.path());
    let l = "Lsystem: 1\nderivation length: 1\nAxiom: ?P(0,0)\nA --> B\n\
             homomorphism\nI --> F\nendlsystem\n";
    let l = write(dir.path(), "plant.l", l);
    let r = axiom_apart(dir.path(), &v, &l, "F[%@?P(0,0)]I?P(0,0)\n");
    assert_eq!(r.ok(), "F[%@?P(0,0)]F?P(0,2)\n");
}

/// A view file whose turtle skips the rest of a branch after `%`.
fn cut_off_view(dir: &Path) -> PathBuf {
    write(
        dir,
        "plant.v",
        "angle factor: 8\ninterpretation past %: off\n",
    )
}

/// lsgen `-n 0` on the `.l` file `l` with the view `v` and the axiom
/// `axiom` given apart (`--axiom`), which the file's checks do not see.
fn axiom_apart(dir: &Path, v: &Path, l: &Path, axiom: &str) -> common::Run {
    let ax = write(dir, "axiom.txt", axiom);
    run(lsgen()
        .args(["-n", "0", "--axiom"])
        .arg(&ax)
        .arg("--cpfg-view")
        .arg(v)
        .arg(l))
}
