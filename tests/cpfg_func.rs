//! cpfg's `func(id, x)` through the real binary (`--functions`; README,
//! "Coming from cpfg: functions"). The expected values are worked out by
//! hand below (straight-line and flat functions, where cpfg's bisection
//! stops at a dyadic parameter); tests/cpfg_random.rs checks random
//! functions against the independent reference tests/tools/cpfg_ref.py.

mod common;

use common::{lsgen, run, tempdir, write};
use std::path::Path;

/// The straight line y = x, old format (`range:`): its 4 control points
/// are equally spaced on the diagonal, so the curve is the line and the
/// point at parameter t is (t, t) (up to the 32-bit rounding of 1/3 and
/// 2/3, below %g's 6 digits).
const LINE_OLD: &str = "range: 0.0 1.0\npoints: 4\n0 0\n0.333333333 0.333333333\n\
                        0.666666667 0.666666667\n1 1\n";

/// Success with nothing on standard error: the output.
fn ok(r: common::Run) -> String {
    r.ok()
}

/// Exit 1 and nothing on standard output: the message.
fn err(r: common::Run) -> String {
    r.fails(1).to_string()
}

fn system(axiom: &str, production: &str) -> String {
    format!("Lsystem: 1\nderivation length: 1\nAxiom: {axiom}\n{production}\nendlsystem\n")
}

/// cpfg bisects the parameter from [0, 1] until x is within 0.001: 0.5,
/// 0.25 and 0.75 are met at the first or second halving, exactly; 0 is met
/// at 2^-10 (0.000976562, the first within 0.001), 1 at 1 - 2^-10
/// (0.999023). x outside [0, 1] is clamped. With 5 samples (x = 0, 0.25,
/// 0.5, 0.75, 1) the table holds those values and `func` interpolates:
/// at 0.375, half of 0.25 and 0.5; at 0.1 (index 0.4),
/// 0.6 * 2^-10 + 0.4 * 0.25 = 0.1005859375, where the search for 0.1
/// goes 0.5, 0.25, 0.125, 0.0625, 0.09375, 0.109375, 0.1015625,
/// 0.09765625 and stops at 0.099609375 (the first within 0.001).
#[test]
fn a_view_file_gives_functions_as_cpfg_reads_them() {
    let dir = tempdir();
    std::fs::create_dir(dir.path().join("fn")).unwrap();
    write(dir.path(), "fn/line.func", LINE_OLD);
    write(dir.path(), "fn/line5.func", LINE_OLD);
    // Other view settings are skipped; comments and the preprocessor work;
    // file names are relative to the view file.
    let view = write(
        dir.path(),
        "fn/plant.v",
        "/* view */\nangle factor: 16\n#define SAMPLES 5\n\
         function: line.func\nfunction:   line5.func SAMPLES /* samples */\nscale: 1.0\n",
    );
    let l = write(
        dir.path(),
        "plant.l",
        system(
            "A(0.5) A(0.25) A(0.75) A(-2) A(3) A(0.375) A(0.1)",
            "A(x) --> B(func(1, x), func(2, x))",
        ),
    );
    let out = ok(run(lsgen().arg(&l).arg("--functions").arg(&view)));
    assert_eq!(
        out,
        "B(0.5,0.5)B(0.25,0.25)B(0.75,0.75)B(0.000976562,0.000976562)\
         B(0.999023,0.999023)B(0.375,0.375)B(0.0996094,0.100586)\n"
    );
    // From another directory, with the functions' numbers truncated.
    let l2 = write(
        dir.path(),
        "trunc.l",
        system("A(0.5)", "A(x) --> B(func(1.9, x), func(2.99, x/2))"),
    );
    let out = ok(run(lsgen()
        .current_dir("/")
        .arg(&l2)
        .arg("--functions")
        .arg(&view)));
    assert_eq!(out, "B(0.5,0.25)\n");
}

/// A function set's names are macros of the `.l` file (cpfg's
/// `-DNAME=N`), numbered with the other `--functions` in order; the new
/// format's multiplicity repeats a point; a flat function gives its
/// height anywhere.
#[test]
fn function_sets_define_their_names() {
    let dir = tempdir();
    let set = write(
        dir.path(),
        "f.fset",
        "funcgalleryver 1 1\nitems: 2\n\
         fver 1 1\nname: flat\nsamples: 10\nflip: off\npoints: 4\n0 2 2\n0.5 2\n0.7 2\n1 2\n\
         fver 1 1\nname: line\nsamples: 0\nflip: off\npoints: 4\n\
         0 0\n0.333333333 0.333333333\n0.666666667 0.666666667\n1 1\n",
    );
    let single = write(dir.path(), "third.func", LINE_OLD);
    let l = write(
        dir.path(),
        "m.l",
        system(
            "A(0.3) A(0.75)",
            "A(x) --> B(func(flat, x), func(line, 0.25), func(3, 0.5), line)",
        ),
    );
    let out = ok(run(lsgen()
        .arg(&l)
        .arg("--functions")
        .arg(&set)
        .arg("--functions")
        .arg(&single)));
    assert_eq!(out, "B(2,0.25,0.5,2)B(2,0.25,0.5,2)\n");
    // The same functions in a batch, and on several threads.
    let l2 = write(
        dir.path(),
        "n.l",
        system("A(0.5)", "A(x) --> C(func(2, x))"),
    );
    let outdir = dir.path().join("out");
    std::fs::create_dir(&outdir).unwrap();
    let r = run(lsgen()
        .args(["-j", "2", "--functions"])
        .arg(&set)
        .arg("--functions")
        .arg(&single)
        .arg("-o")
        .arg(outdir.join("{stem}.txt"))
        .arg(&l)
        .arg(&l2));
    ok(r);
    let read = |n: &str| std::fs::read_to_string(outdir.join(n)).unwrap();
    assert_eq!(read("m.txt"), "B(2,0.25,0.5,2)B(2,0.25,0.5,2)\n");
    assert_eq!(read("n.txt"), "C(0.5)\n");
}

/// In a view file, as in cpfg (`interpret.c`, `splinearr.cpp`): a
/// `function set:` replaces the functions listed before it (`Reset`), and
/// a `function:` after it ends the set's names (they are no macros then:
/// an unknown name is 0, with a warning, as cpfg reads it).
#[test]
fn a_view_files_set_replaces_what_came_before() {
    let dir = tempdir();
    let d = dir.path();
    write(d, "line.func", LINE_OLD);
    write(
        d,
        "s.fset",
        "funcgalleryver 1 1\nitems: 1\n\
         fver 1 1\nname: flat\nsamples: 0\nflip: off\npoints: 4\n0 3\n0.3 3\n0.6 3\n1 3\n",
    );
    let l = write(d, "m.l", system("A(0.25)", "A(x) --> B(func(1, x), flat)"));
    let v = write(d, "a.v", "function: line.func\nfunction set: s.fset\n");
    let out = ok(run(lsgen().arg(&l).arg("--functions").arg(&v)));
    assert_eq!(out, "B(3,1)\n");
    let v = write(d, "b.v", "function set: s.fset\nfunction: line.func\n");
    let r = run(lsgen().arg(&l).arg("--functions").arg(&v));
    assert!(r.stderr.contains("warning"), "{}", r.stderr);
    assert_eq!(r.code(), Some(0), "{}", r.stderr);
    assert_eq!(r.out(), "B(3,0)\n");
}

#[test]
fn func_without_function_files_names_the_view_file_beside() {
    let dir = tempdir();
    let src = system("A(1)", "A(x) --> B(func(1, x))");
    let l = write(dir.path(), "plant.l", &src);
    let e = err(run(lsgen().arg(&l)));
    assert!(
        e.contains(":4:12: error: `func` needs the model's function files: give its view file (`function:` lines) or its `.func` files with `--functions FILE`"),
        "{e}"
    );
    write(dir.path(), "plant.v", "function: x.func\n");
    let e = err(run(lsgen().arg(&l)));
    let v = dir.path().join("plant.v");
    assert!(
        e.contains(&format!(
            "give its view file with `--functions {}`",
            v.display()
        )),
        "{e}"
    );
}

/// Errors, each located: a file the view names that does not exist (at
/// the view's line), a function file that is none, too few points, a curve
/// that never reaches some x (cpfg would search forever), a function
/// number that is no function (at the call, in the step).
#[test]
fn bad_functions_are_located_errors() {
    let dir = tempdir();
    let d = dir.path();
    let l = write(d, "m.l", system("A(0.5)", "A(x) --> B(func(1, x))"));
    let with = |f: &Path| run(lsgen().arg(&l).arg("--functions").arg(f));

    let v = write(d, "missing.v", "scale: 1\nfunction:  nope.func 10\n");
    let e = err(with(&v));
    assert!(
        e.starts_with(&format!(
            "lsgen: {}:2:12: error: cannot read `{}`: No such file or directory",
            v.display(),
            d.join("nope.func").display()
        )),
        "{e}"
    );
    assert!(
        e.contains("\nfunction:  nope.func 10\n           ^\n"),
        "{e}"
    );

    let f = write(
        d,
        "bad.func",
        "fver 1 1\nname: x\nsamples: 0\nflip: off\npoints: 3\n0 0\n0.5 1\n1 0\n",
    );
    let e = err(with(&f));
    assert!(
        e.contains("bad.func:5:1: error: a function needs at least 4 control points"),
        "{e}"
    );

    let f = write(
        d,
        "short.func",
        "range: 0 1\npoints: 4\n0 0\n0.1 0\n0.2 0\n0.4 0\n",
    );
    // Sampled: refused when read.
    let v = write(d, "short.v", "function: short.func 10\n");
    let e = err(with(&v));
    assert!(
        e.contains("short.func:1:1: error: the curve never comes within 0.001 of x ="),
        "{e}"
    );
    // Not sampled: at the call that asks for such an x; one it reaches is fine.
    let e = err(with(&f));
    assert!(
        e.contains("m.l:4:12: error: func(1, 0.5): the curve never comes within 0.001 of x = 0.5"),
        "{e}"
    );
    let near = write(d, "near.l", system("A(0.1)", "A(x) --> B(func(1, x))"));
    assert!(run(lsgen().arg(&near).arg("--functions").arg(&f))
        .status
        .success());

    let line = write(d, "line.func", LINE_OLD);
    let three = write(d, "three.l", system("A(0.5)", "A(x) --> B(func(3, x))"));
    let r = run(lsgen().arg(&three).arg("--functions").arg(&line));
    let e = err(r);
    assert!(
        e.contains("three.l:4:12: error: func(3, x): there is no function 3; the function files define 1 to 1 (in step 1)"),
        "{e}"
    );

    // A `.func` or `.fset` file whose first line is wrong is refused, not
    // read as a view file without functions (that would renumber the
    // files after it); a view file without functions gives none.
    let e = err(with(&write(d, "blank.func", format!("\n{LINE_OLD}"))));
    assert!(
        e.contains("blank.func:1:1: error: not a cpfg function file"),
        "{e}"
    );
    let e = err(with(&write(d, "blank.fset", "\nfuncgalleryver 1 1\n")));
    assert!(
        e.contains("blank.fset:1:1: error: not a cpfg function file"),
        "{e}"
    );
    let quiet = write(d, "quiet.l", system("A(0.5)", "A(x) --> B(x)"));
    let empty = write(d, "empty.v", "/* nothing */\nangle factor: 12\n");
    let r = run(lsgen().arg(&quiet).arg("--functions").arg(&empty));
    assert_eq!(ok(r), "B(0.5)\n");
    // A byte-order mark is skipped; a byte that is no UTF-8 in a view
    // file's comment is read as cpfg reads it.
    let bom = write(d, "bom.func", format!("\u{feff}{LINE_OLD}"));
    assert_eq!(ok(with(&bom)), "B(0.5)\n");
    let latin = d.join("latin.v");
    std::fs::write(&latin, b"/* \xa9 1998 */\nfunction: line.func\n").unwrap();
    assert_eq!(ok(with(&latin)), "B(0.5)\n");
    // Places: an empty `function:` at its colon, too many samples at the
    // line that asks for them.
    let e = err(with(&write(d, "nofile.v", "scale: 1\nfunction:   \n\n")));
    assert!(
        e.contains("nofile.v:2:9: error: `function:` needs a file name"),
        "{e}"
    );
    let e = err(with(&write(d, "many.v", "function: line.func 70000\n")));
    assert!(
        e.contains("many.v:1:11: error: more than 65536 samples"),
        "{e}"
    );
    let many =
        "fver 1 1\nname: a\nsamples: 99999999\nflip: off\npoints: 4\n0 0\n0.3 0.3\n0.6 0.6\n1 1\n";
    let e = err(with(&write(d, "many.func", many)));
    assert!(
        e.contains("many.func:3:1: error: more than 65536 samples"),
        "{e}"
    );
    // An id far out of range is shown as a number is.
    let big = write(d, "big.l", system("A(0.5)", "A(x) --> B(func(1.0e300, x))"));
    let e = err(run(lsgen().arg(&big).arg("--functions").arg(&line)));
    assert!(
        e.contains("func(1e300, x): there is no function 1e300"),
        "{e}"
    );

    let e = err(with(&write(d, "text.func", "fver 1 1\n")));
    assert!(
        e.contains("text.func:2:1: error: expected `name: NAME`"),
        "{e}"
    );
    let e = err(with(&write(d, "set.fset", "funcgalleryver 2 0\n")));
    assert!(
        e.contains("set.fset:1:1: error: function set version 2.0 is not supported"),
        "{e}"
    );
}

/// The func and curve models of tests/cpfg/func (their own view, function, set and contour
/// files): lsgen with `--functions NAME.v` prints what the independent
/// reference tests/tools/cpfg_ref.py derived (tests/expected/cpfg/func/,
/// kept current by `gen_expected_cpfg.py --check`).
#[test]
fn func_models_match_the_reference() {
    let root = Path::new(common::ROOT);
    let expected = root.join("tests/expected/cpfg/func");
    let mut n = 0;
    for e in std::fs::read_dir(&expected).unwrap() {
        let path = e.unwrap().path();
        let file = path.file_name().unwrap().to_str().unwrap().to_string();
        let Some((name, steps)) = file.strip_suffix(".txt").and_then(|f| f.rsplit_once(".n"))
        else {
            continue;
        };
        let model = root.join("tests/cpfg/func").join(format!("{name}.l"));
        let view = root.join("tests/cpfg/func").join(format!("{name}.v"));
        let out = ok(run(lsgen()
            .args(["-n", steps])
            .arg(&model)
            .arg("--functions")
            .arg(&view)));
        assert_eq!(out, std::fs::read_to_string(&path).unwrap(), "{file}");
        n += 1;
    }
    assert_eq!(n, 8);
}

/// cpfg's curves (README, "Coming from cpfg: curves"): contour files whose
/// values are worked out by hand.
///
/// - `line.con`: control points k (3, 4), k = 0..3, a uniform B-spline
///   (no `type:`): at knot parameter u the curve is (u - 2)(3, 4), and u
///   runs from 3 to 3 + (4 - 3.000001) (cpfg's 3.000001 keeps u inside the
///   last span). So the curve is a segment from (3, 4) to
///   (1 + 0.999999)(3, 4), at constant speed: the chords' length is
///   5 * 0.999999 = 4.999995 whatever the samples, and
///   curveX(t) = 3 + 2.999997 t, curveY(t) = 4 + 3.999996 t.
///   (curveX(1, 1) - 5.99999) 1e6 = 7 and (curveGAL(1) - 4.99999) 1e6 = 5
///   show the 1e-6.
/// - `line3.con`: the same in 3D, points k (1, 2, 2): curveZ(t) =
///   2 + 1.999998 t.
/// - `square.con`: the closed B-spline of the square's corners (1, 1),
///   (-1, 1), (-1, -1), (1, -1) starts at (P0 + 4 P1 + P2) / 6 =
///   (-2/3, 2/3).
/// - `end.con`: `bspline-endpoint` (clamped knots) runs from the first
///   control point (0, 0) to the last (4, 0.5), up to 1e-6 of the last
///   chord (3, 0.5) to (4, 0.5): x 3.999997.
/// - functions and curves are numbered apart: `func(1, 0.5)` is the line
///   y = x's (0.5) though `curve:` lines come first; an id 1.9 is 1.
const CURVE_LINE: &str = "version: 1.4\ncontact: 0 0 0\nend: 0 0 0\nheading: 0 1 0\nup: 0 0 -1\n\
                          size: 1\npoints: 4\nrange: 0.0 1.0\n0 0\n3 4\n6 8\n9 12\n";

fn curve_files(d: &Path) {
    write(d, "line.con", CURVE_LINE);
    write(
        d,
        "line3.con",
        "points: 4\ndimension: 3\n0 0 0\n1 2 2\n2 4 4\n3 6 6\n",
    );
    write(
        d,
        "square.con",
        "points: 4\ntype: bspline-closed\ndimension: 4\n1 1 0 1\n-1 1 0 1\n-1 -1 0 1\n1 -1 0 1\n",
    );
    write(
        d,
        "end.con",
        "points: 5\ntype: bspline-endpoint\n0 0\n1 2\n2 -1\n3 0.5\n4 0.5\n",
    );
    write(d, "line.func", LINE_OLD);
}

#[test]
fn a_view_file_gives_curves_apart_from_functions() {
    let dir = tempdir();
    let d = dir.path();
    curve_files(d);
    let view = write(
        d,
        "m.v",
        "angle factor: 8\ncurve: line.con 10\nfunction: line.func\ncontour sides: 7\n\
         curve: line3.con\ncurve: square.con 11\ncurve: end.con\n",
    );
    let l = write(
        d,
        "m.l",
        system(
            "A(0) A(1) A(-3) A(7)",
            "A(x) --> B(curveX(1, x), curveY(1, x), (curveX(1, 1) - 5.99999) * 1000000, \
             (curveGAL(1) - 4.99999) * 1000000, curveZ(2, x), curveX(3, 0), curveY(3, 0), \
             curveX(4, x), curveY(4, x), func(1, 0.5), curveX(1.9, 0))",
        ),
    );
    let out = ok(run(lsgen().arg(&l).arg("--functions").arg(&view)));
    let at0 = "B(3,4,7,5,2,-0.666667,0.666667,0,0,0.5,3)";
    let at1 = "B(6,8,7,5,4,-0.666667,0.666667,4,0.5,0.5,3)";
    // (t below 0 is 0, above 1 is 1)
    assert_eq!(out, format!("{at0}{at1}{at0}{at1}\n"));
    // Halfway, and the contour files given directly (`--curves`, the same
    // option; 100 samples each), the function file too.
    let l = write(
        d,
        "half.l",
        system(
            "A(0.5)",
            "A(x) --> B(curveX(1, x), curveY(1, x), curveZ(2, 0.25), curveZ(1, x), (curveGAL(2) - 2.99999) * 1000000)",
        ),
    );
    let mut cmd = lsgen();
    cmd.arg(&l);
    for f in ["line.con", "line3.con", "line.func"] {
        cmd.arg("--curves").arg(d.join(f));
    }
    // 3 + 1.4999985, 4 + 1.999998, 2 + 0.4999995; a 2D curve's z is 0;
    // curveGAL(2) = 3 * 0.999999 = 2.999997.
    assert_eq!(ok(run(&mut cmd)), "B(4.5,6,2.5,0,7)\n");
    // Samples: with 2, curveGAL is the one chord from the start (0, 0) to
    // the end (4 - 3e-6, 0.5): sqrt(16.25) = 4.03113 (to 6 digits); a
    // `curve:` line without SAMPLES has 100, as a file given directly.
    let v = write(
        d,
        "s.v",
        "curve: end.con 2\ncurve: end.con\ncurve: end.con 100\n",
    );
    let l = write(
        d,
        "s.l",
        system(
            "A(0.3)",
            "A(x) --> B(curveGAL(1), curveGAL(2) == curveGAL(3), curveX(2, x) == curveX(3, x), \
             curveGAL(2) == curveGAL(4), curveGAL(3) > curveGAL(1))",
        ),
    );
    let out = ok(run(lsgen()
        .arg(&l)
        .arg("--functions")
        .arg(&v)
        .arg("--curves")
        .arg(d.join("end.con"))));
    assert_eq!(out, "B(4.03113,1,1,1,1)\n");
}

#[test]
fn bad_curves_are_located_errors() {
    let dir = tempdir();
    let d = dir.path();
    curve_files(d);
    let l = write(d, "m.l", system("A(0.5)", "A(x) --> B(curveX(1, x))"));
    let with = |f: &Path| run(lsgen().arg(&l).arg("--functions").arg(f));

    // The file a view line names, and its SAMPLES, at that line.
    let v = write(d, "missing.v", "scale: 1\ncurve:  nope.con 10\n");
    let e = err(with(&v));
    assert!(
        e.starts_with(&format!(
            "lsgen: {}:2:9: error: cannot read `{}`: No such file or directory",
            v.display(),
            d.join("nope.con").display()
        )),
        "{e}"
    );
    let e = err(with(&write(d, "one.v", "curve: line.con 1\n")));
    assert!(
        e.contains("one.v:1:8: error: a curve needs at least 2 samples"),
        "{e}"
    );
    let e = err(with(&write(d, "nofile.v", "curve:\n")));
    assert!(
        e.contains("nofile.v:1:6: error: `curve:` needs a file name"),
        "{e}"
    );
    // A contour file's faults at their lines (cpfg reads out of bounds or
    // past its buffer there).
    for (text, place, msg) in [
        (
            "points: 4\n0 0\n1 x y\n",
            "3:1",
            "expected a point `X Y` (dimension 2)",
        ),
        (
            "0 0\npoints: 4\n",
            "1:1",
            "expected `points: N` before the points",
        ),
        (
            "points: 4\n0 0\n1 1\n2 2\n3 3",
            "5:1",
            "expected a newline at the end of the last line",
        ),
        (
            "points: 2\ndimension: 4\n0 0 0 -1\n",
            "3:1",
            "expected a multiplicity of 0 or more",
        ),
        (
            "points: 1\n0 0\n1 1\n",
            "3:1",
            "expected no more points than `points:` gives",
        ),
        (
            "points: 4\ntype: bezier-surface\n",
            "2:1",
            "lsgen does not read `type: bezier-surface`",
        ),
        (
            "points: 3\n0 0\n1 1\n2 2\n",
            "1:1",
            "a curve needs at least 4 control points",
        ),
    ] {
        let f = write(d, "bad.con", text);
        let e = err(with(&f));
        assert!(
            e.contains(&format!("bad.con:{place}: error: {msg}")),
            "{text:?}: {e}"
        );
    }

    // At the call: an id that is no curve, a t that is no number, a curve
    // of length 0 (cpfg divides 0 by 0); its curveGAL is 0.
    let line = d.join("line.con");
    let calls = |call: &str| {
        let m = write(d, "c.l", system("A(0.5)", &format!("A(x) --> B({call})")));
        run(lsgen().arg(&m).arg("--curves").arg(&line))
    };
    let e = err(calls("curveX(2, x)"));
    assert!(
        e.contains("c.l:4:12: error: curveX(2, ...): there is no curve 2; the view files define 1 to 1 (in step 1)"),
        "{e}"
    );
    let e = err(calls("curveGAL(0.5)"));
    assert!(e.contains("curveGAL(0, ...): there is no curve 0"), "{e}");
    let e = err(calls("curveY(1, (0 - 1) ^ 0.5)"));
    assert!(
        e.contains("c.l:4:12: error: curveY(id, t) with t not a number"),
        "{e}"
    );
    let zero = write(d, "zero.con", "points: 4\n0 0\n0 0\n0 0\n0 0\n");
    let m = write(
        d,
        "z.l",
        system("A(0.5)", "A(x) --> B(curveGAL(1)) C(curveZ(1, x))"),
    );
    let e = err(run(lsgen().arg(&m).arg("--curves").arg(&zero)));
    assert!(
        e.contains("z.l:4:27: error: curveZ(1, 0.5): curve 1 has no arc-length parameter there"),
        "{e}"
    );
    let m = write(d, "g.l", system("A(0.5)", "A(x) --> B(curveGAL(1))"));
    assert_eq!(
        ok(run(lsgen().arg(&m).arg("--curves").arg(&zero))),
        "B(0)\n"
    );

    // Functions without curves: curveX is refused where it is written.
    let e = err(run(lsgen()
        .arg(&l)
        .arg("--functions")
        .arg(d.join("line.func"))));
    assert!(
        e.contains("m.l:4:12: error: `curveX` needs the model's curves: give its view file (`curve:` lines) or its `.con` files with `--functions FILE`"),
        "{e}"
    );
}
