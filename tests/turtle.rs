//! lsgen-turtle, the real binary: segment lists against the independent
//! Python turtle (tests/tools/turtle.py, expected files in
//! tests/expected/turtle/), hand-derived frames, SVG/PNG/OBJ structure,
//! errors, broken pipes and `-o` atomicity.

mod common;

use common::{lsgen, lsgen_in_root, run, run_with_stdin, Run, ROOT};
use std::io::{Read, Write};
use std::path::Path;
use std::process::Stdio;

/// lsgen's output for `args` (run from the repository root).
fn derive(args: &[&str]) -> Vec<u8> {
    let r = run(lsgen_in_root().args(args));
    r.assert_no_crash();
    assert!(r.status.success(), "{}: {}", r.what, r.stderr);
    r.stdout
}

/// lsgen-turtle with `input` on standard input.
fn turtle(args: &[&str], input: &[u8]) -> Run {
    let r = run_with_stdin(common::turtle().args(args).current_dir(ROOT), input);
    r.assert_no_crash();
    r
}

fn ok(r: &Run) -> Vec<u8> {
    assert!(
        r.status.success() && r.stderr.is_empty(),
        "{}: exit {:?}, stderr:\n{}",
        r.what,
        r.code(),
        r.stderr
    );
    r.stdout.clone()
}

fn text(b: Vec<u8>) -> String {
    String::from_utf8(b).unwrap()
}

/// What lsgen-turtle says of a one-line ASCII input on standard input at
/// its byte `at` (0-based): `<stdin>:1:COL`, and for a short line (an
/// excerpt is cut from a longer one) the line and a caret under it.
fn assert_located(stderr: &str, input: &[u8], at: usize, message: &str) {
    let head = format!("lsgen-turtle: <stdin>:1:{}: {message}\n", at + 1);
    if input.len() <= 140 {
        let line = String::from_utf8_lossy(input);
        let want = format!("{head}{line}\n{}^\n", " ".repeat(at));
        assert_eq!(stderr, want);
    } else {
        assert!(stderr.starts_with(&head), "{stderr}");
        assert_eq!(stderr.lines().count(), 3, "{stderr}");
        assert!(stderr.ends_with("^\n"), "{stderr}");
    }
}

/// Compare two segment lists: same lines, same words, numbers within 1e-6.
fn same_segments(got: &str, want: &str, what: &str) {
    let g: Vec<&str> = got.lines().collect();
    let w: Vec<&str> = want.lines().collect();
    assert_eq!(g.len(), w.len(), "{what}: line counts differ");
    for (i, (a, b)) in g.iter().zip(&w).enumerate() {
        let (aw, bw): (Vec<&str>, Vec<&str>) = (a.split(' ').collect(), b.split(' ').collect());
        assert_eq!(aw.len(), bw.len(), "{what}: line {}: {a:?} vs {b:?}", i + 1);
        for (x, y) in aw.iter().zip(&bw) {
            match (x.parse::<f64>(), y.parse::<f64>()) {
                (Ok(x), Ok(y)) => assert!(
                    (x - y).abs() <= 1e-6 * (1.0 + y.abs()),
                    "{what}: line {}: {a:?} vs {b:?}",
                    i + 1
                ),
                _ => assert_eq!(x, y, "{what}: line {}", i + 1),
            }
        }
    }
}

#[test]
fn segments_match_the_reference_turtle() {
    let dir = Path::new(ROOT).join("tests/expected/turtle");
    let mut n = 0;
    for e in std::fs::read_dir(&dir).unwrap() {
        let path = e.unwrap().path();
        let name = path.file_name().unwrap().to_str().unwrap().to_string();
        // NAME.nN.txt
        let Some((model, rest)) = name.split_once(".n") else {
            continue;
        };
        let steps = rest.trim_end_matches(".txt");
        // An example, else a test model of tests/turtle/.
        let mut ls = format!("examples/{model}.ls");
        if !Path::new(ROOT).join(&ls).exists() {
            ls = format!("tests/turtle/{model}.ls");
        }
        let string = derive(&["-n", steps, &ls]);
        let got = text(ok(&turtle(&["--ls", &ls, "-f", "segments"], &string)));
        let want = std::fs::read_to_string(&path).unwrap();
        same_segments(&got, &want, &name);
        n += 1;
    }
    assert!(n >= 8, "only {n} expected files");
}

#[test]
fn initial_frame_and_rotations_by_hand() {
    // Heading up the screen (+Y); + turns left (towards -X); & pitches
    // towards U = -Z; / rolls L towards U; | turns around.
    let seg = |s: &str| {
        text(ok(&turtle(
            &["-f", "segments", "--angle", "90"],
            s.as_bytes(),
        )))
    };
    assert_eq!(seg("F"), "0 0 0 0 1 0 1 0\n");
    same_segments(&seg("+F"), "0 0 0 -1 0 0 1 0\n", "+");
    same_segments(&seg("F(2)-F"), "0 0 0 0 2 0 1 0\n0 2 0 1 2 0 1 0\n", "-");
    same_segments(&seg("&F"), "0 0 0 0 0 -1 1 0\n", "&");
    same_segments(&seg("^F"), "0 0 0 0 0 1 1 0\n", "^");
    // After /, L points along U = -Z: + then turns towards -Z.
    same_segments(&seg("/+F"), "0 0 0 0 0 -1 1 0\n", "/");
    same_segments(&seg("\\+F"), "0 0 0 0 0 1 1 0\n", "\\");
    same_segments(&seg("|F"), "0 0 0 0 -1 0 1 0\n", "|");
    // Parameters: angle, length, width, colour; f and g move only.
    same_segments(
        &seg("+(30)F(2)f!(3);(2)G"),
        &format!(
            "0 0 0 -1 {s3} 0 1 0\n-1.5 {a} 0 -2 {b} 0 3 2\n",
            s3 = 3f64.sqrt(),
            a = 1.5 * 3f64.sqrt(),
            b = 2.0 * 3f64.sqrt()
        ),
        "parameters",
    );
    // Branches restore position, width and colour.
    same_segments(
        &seg("[!(5)'F]F"),
        "0 0 0 0 1 0 5 1\n0 0 0 0 1 0 1 0\n",
        "[]",
    );
    // A polygon: { starts, . and f record vertices (cpfg), F draws and records.
    same_segments(
        &seg("{.f+f+f}"),
        "polygon 0 0 0 0 0 1 0 -1 1 0 -1 0 0\n",
        "polygon",
    );
    // $ levels L as cpfg's @v does (blackbox.c) and ABOP p. 57 says:
    // L = Y x H / |Y x H|, U = L x H. After a pitch and a roll, L is
    // horizontal again: for H leaning towards -Z (after &) L = -X, for H
    // leaning towards +Z (after ^) L = +X.
    same_segments(&seg("&(45)/(30)$+F"), "0 0 0 -1 0 0 1 0\n", "$");
    same_segments(&seg("^(45)/(30)$+F"), "0 0 0 1 0 0 1 0\n", "$");
    // U then points down, so & after $ pitches down (ABOP's "pitch down"):
    // heading right along +X, $ and & go to -Y; ^ to +Y.
    same_segments(&seg("-$&F"), "0 0 0 0 -1 0 1 0\n", "$&");
    same_segments(&seg("-$^F"), "0 0 0 0 1 0 1 0\n", "$^");
    // $ is a roll: a frame it has levelled is left as it is, and @v is $.
    for s in ["-(30)&(20)/(70)", "^(10)+(100)\\(45)", "&(89)/(5)"] {
        let once = seg(&format!("{s}$+F&F"));
        same_segments(&seg(&format!("{s}$$+F&F")), &once, "$$");
        same_segments(&seg(&format!("{s}@v+F&F")), &once, "@v");
        same_segments(&seg(&format!("{s}$/(0)$+F&F")), &once, "$ $");
    }
    // Straight up or down there is no horizontal L: $ leaves the frame.
    same_segments(&seg("$+F"), &seg("+F"), "$ vertical");
    same_segments(&seg("|$+F"), &seg("|+F"), "$ vertical");
    // @o and @O draw dots; other modules are ignored.
    same_segments(
        &seg("F@o(2)XYZ@O"),
        "0 0 0 0 1 0 1 0\ndot 0 1 0 2 0\nsphere 0 1 0 1 0\n",
        "@o",
    );
}

#[test]
fn view_settings_from_ls_and_options() {
    let dir = tempfile::tempdir().unwrap();
    let ls = dir.path().join("m.ls");
    std::fs::write(
        &ls,
        "/* view: angle = 1 */\nview: angle = 90\nview: step = 2\nview: width = 0.5\n\
         view: tropism = 1 0 0\nderivation length: 1\naxiom: F\nview: step = 7\n",
    )
    .unwrap();
    let ls = ls.to_str().unwrap();
    let seg = |args: &[&str], s: &str| {
        let mut a = vec!["-f", "segments", "--ls", ls];
        a.extend_from_slice(args);
        text(ok(&turtle(&a, s.as_bytes())))
    };
    same_segments(&seg(&[], "+F"), "0 0 0 -2 0 0 0.5 0\n", "from --ls");
    same_segments(
        &seg(&["--step", "3", "--width", "2"], "+F"),
        "0 0 0 -3 0 0 2 0\n",
        "options",
    );
    // Tropism: after each F the heading bends by e|H x T| towards T.
    let got = seg(&["--elasticity", "0.5"], "FF");
    let a = 0.5f64; // |H x T| = 1 for H = +Y, T = +X
    same_segments(
        &got,
        &format!(
            "0 0 0 0 2 0 0.5 0\n0 2 0 {} {} 0 0.5 0\n",
            2.0 * a.sin(),
            2.0 + 2.0 * a.cos()
        ),
        "tropism",
    );
}

/// `--ls -` reads the view lines from standard input, as lsgen reads `-`,
/// when the string comes from a file (it was a file named `-`: "cannot
/// open"); with the string on standard input too, a usage error. A spool
/// file that cannot be made names its directory, as lsgen's message does
/// (both found by the review helper).
#[test]
fn view_lines_from_standard_input_and_the_spools_directory() {
    let dir = tempfile::tempdir().unwrap();
    let s = dir.path().join("s.txt");
    std::fs::write(&s, "+F").unwrap();
    let s = s.to_str().unwrap();
    let header = b"view: angle = 90\nview: step = 2\naxiom: F\n";
    let got = text(ok(&turtle(&["-f", "segments", "--ls", "-", s], header)));
    same_segments(&got, "0 0 0 -2 0 0 1 0\n", "--ls -");
    // Also by the stream's names (an empty picture, exit 0, before: found
    // by the hostile review of lsgen-turtle).
    let v = dir.path().join("in.v");
    std::fs::write(&v, "#include \"/dev/stdin\"\n").unwrap();
    let v = v.to_str().unwrap();
    for (args, option) in [
        (&["-f", "segments", "--ls", "-"][..], "--ls"),
        (&["--ls", "-", "-"], "--ls"),
        (&["-f", "segments", "--ls", "/dev/stdin"], "--ls"),
        (&["-f", "segments", "--ls", "-", "/dev/stdin"], "--ls"),
        (
            &["-f", "segments", "--cpfg-view", "/dev/stdin"],
            "--cpfg-view",
        ),
        (&["-f", "segments", "--colormap", "/dev/fd/0"], "--colormap"),
        (
            &["-f", "segments", "--materials", "/dev/stdin", "-"],
            "--materials",
        ),
    ] {
        let r = turtle(args, b"+F");
        assert_eq!(r.code(), Some(2), "{args:?}: {}", r.stderr);
        let message = format!(
            "lsgen-turtle: error: the module string and `{option}` cannot both come from standard input: give the string's file\n"
        );
        assert_eq!(r.stderr, message, "{args:?}");
    }
    let r = turtle(&["-f", "segments", "--cpfg-view", v], b"+F");
    assert_eq!(r.code(), Some(1), "{}", r.stderr);
    assert!(
        r.stderr
            .contains("in.v:1:10: error: cannot include `/dev/stdin`: it is standard input"),
        "{}",
        r.stderr
    );
    let missing = dir.path().join("missing");
    let r = run_with_stdin(
        common::turtle()
            .args(["-f", "svg"])
            .env("TMPDIR", &missing)
            .current_dir(ROOT),
        b"F+F",
    );
    r.assert_no_crash();
    assert_eq!(r.code(), Some(1), "{}", r.stderr);
    let want = format!(
        "lsgen-turtle: {}: error: cannot create a temporary file",
        missing.display()
    );
    assert!(r.stderr.starts_with(&want), "{}", r.stderr);
}

/// A `view:` setting may hold comments and any blanks (the no-break
/// space here) between its words, as lsgen's lexer reads it (lsgen
/// 9b99c7d ended a setting at its first comment).
#[test]
fn view_settings_with_comments_and_unicode_blanks() {
    let dir = tempfile::tempdir().unwrap();
    let ls = dir.path().join("m.ls");
    std::fs::write(
        &ls,
        "view: angle = /* c */ 90\nview:\u{a0}step\u{a0}=\u{a0}2\u{a0}/* c */\n\
         view: width /* a */ = /* b */ 0.5\nview: width /* c */ increment = 1\naxiom: F\n",
    )
    .unwrap();
    let got = text(ok(&turtle(
        &["-f", "segments", "--ls", ls.to_str().unwrap()],
        b"+F#F",
    )));
    same_segments(
        &got,
        "0 0 0 -2 0 0 0.5 0\n-2 0 0 -4 0 0 1.5 0\n",
        "view lines",
    );
}

fn svg_numbers(svg: &str, attr: &str) -> Vec<f64> {
    let key = format!(" {attr}=\"");
    let i = svg.find(&key).unwrap() + key.len();
    let j = svg[i..].find('"').unwrap();
    svg[i..i + j]
        .split([' ', ','])
        .map(|x| x.parse().unwrap())
        .collect()
}

#[test]
fn svg_merges_segments_and_fills_polygons() {
    let svg = text(ok(&turtle(
        &["--angle", "90", "--size", "200"],
        b"FFF+F[-F]F!(2)F{.F+F+F}",
    )));
    assert!(
        svg.starts_with("<svg xmlns=\"http://www.w3.org/2000/svg\""),
        "{svg}"
    );
    assert!(svg.trim_end().ends_with("</svg>"));
    // FFF+F[-F] is one polyline of 6 points (the branch starts where it
    // ends); F after ] starts another, a new width a third, and the
    // polygon's F+F+F continue it (drawn, as cpfg does).
    assert_eq!(svg.matches("<polyline").count(), 3, "{svg}");
    let mut at = 0;
    for want in [6, 2, 5] {
        let i = at + svg[at..].find("<polyline").unwrap();
        assert_eq!(svg_numbers(&svg[i..], "points").len(), 2 * want, "{svg}");
        at = i + 1;
    }
    assert_eq!(svg.matches("<polygon").count(), 1);
    let vb = svg_numbers(&svg, "viewBox");
    assert_eq!(vb[0], 0.0);
    assert_eq!(vb[1], 0.0);
    assert_eq!(vb[2].max(vb[3]), 200.0);
    // Every point lies inside the view box.
    for p in svg.split("points=\"").skip(1) {
        for xy in p[..p.find('"').unwrap()].split(' ') {
            let (x, y) = xy.split_once(',').unwrap();
            let (x, y): (f64, f64) = (x.parse().unwrap(), y.parse().unwrap());
            assert!(
                x > 0.0 && x < vb[2] && y > 0.0 && y < vb[3],
                "{xy} outside {vb:?}"
            );
        }
    }
}

#[test]
fn svg_from_stdin_equals_svg_from_file() {
    let string = derive(&["-n", "3", "examples/plant_e.ls"]);
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("s.txt");
    std::fs::write(&f, &string).unwrap();
    let args = ["--ls", "examples/plant_e.ls"];
    let a = ok(&turtle(&args, &string));
    let mut args2 = args.to_vec();
    args2.push(f.to_str().unwrap());
    let b = ok(&turtle(&args2, b""));
    assert!(a.len() > 1000);
    assert_eq!(a, b);
}

#[test]
fn views_project_3d_models() {
    // Up the screen in the front view; along -Z seen from the side or top.
    let seg = |view: &str| {
        text(ok(&turtle(
            &["--view", view, "--size", "100", "--width", "0"],
            b"&(90)F",
        )))
    };
    let front = seg("front");
    let side = seg("side");
    let top = seg("top");
    // front: a degenerate point; side: horizontal line; top: vertical line.
    let pts = |s: &str| svg_numbers(&s[s.find("<polyline").unwrap()..], "points");
    let f = pts(&front);
    assert_eq!((f[0], f[1]), (f[2], f[3]));
    let s = pts(&side);
    assert!(s[0] < s[2] && s[1] == s[3], "side {s:?}"); // -Z is to the right seen from +X
    let t = pts(&top);
    assert!(t[1] > t[3] && t[0] == t[2], "top {t:?}"); // -Z is up seen from above
    assert_eq!(seg("90 0"), side);
    assert_eq!(seg("0,90"), top);
    // --twist turns the picture on the screen: F (up) becomes a line to
    // the left for +90, as + would turn it.
    let twisted = text(ok(&turtle(
        &["--twist", "90", "--size", "100", "--width", "0"],
        b"F",
    )));
    let p = pts(&twisted);
    assert!(p[0] > p[2] && (p[1] - p[3]).abs() < 1e-9, "twist {p:?}");
}

fn decode_png(data: &[u8]) -> (u32, u32, Vec<u8>) {
    let d = png::Decoder::new(data);
    let mut r = d.read_info().unwrap();
    let mut buf = vec![0; r.output_buffer_size()];
    let info = r.next_frame(&mut buf).unwrap();
    buf.truncate(info.buffer_size());
    // As RGBA, whatever was written.
    let px = match info.color_type {
        png::ColorType::Rgba => buf,
        png::ColorType::Rgb => buf
            .chunks(3)
            .flat_map(|c| [c[0], c[1], c[2], 255])
            .collect(),
        t => panic!("unexpected colour type {t:?}"),
    };
    (info.width, info.height, px)
}

#[test]
fn png_matches_the_svg() {
    let string = derive(&["examples/plant_a.ls"]);
    let args = ["--ls", "examples/plant_a.ls", "--size", "300"];
    let svg = text(ok(&turtle(&args, &string)));
    let mut a = args.to_vec();
    a.extend(["-f", "png"]);
    let png = ok(&turtle(&a, &string));
    let (w, h, px) = decode_png(&png);
    let vb = svg_numbers(&svg, "viewBox");
    assert_eq!((w as f64, h as f64), (vb[2], vb[3]));
    // The drawn pixels' box against the SVG's points, widened by the stroke.
    let sw = svg_numbers(&svg, "stroke-width")[0];
    let (mut x0, mut y0, mut x1, mut y1) = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
    for p in svg.split("points=\"").skip(1) {
        for xy in p[..p.find('"').unwrap()].split(' ') {
            let (x, y) = xy.split_once(',').unwrap();
            let (x, y): (f64, f64) = (x.parse().unwrap(), y.parse().unwrap());
            (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
        }
    }
    let (mut px0, mut py0, mut px1, mut py1) = (u32::MAX, u32::MAX, 0, 0);
    for y in 0..h {
        for x in 0..w {
            let i = ((y * w + x) * 4) as usize;
            // Background is white; anything darker is drawn.
            if px[i] < 200 || px[i + 1] < 200 || px[i + 2] < 200 {
                (px0, py0, px1, py1) = (px0.min(x), py0.min(y), px1.max(x), py1.max(y));
            }
        }
    }
    assert!(px0 <= px1, "nothing drawn");
    let tol = sw / 2.0 + 1.5;
    for (got, want) in [
        (px0 as f64, x0),
        (py0 as f64, y0),
        (px1 as f64 + 1.0, x1),
        (py1 as f64 + 1.0, y1),
    ] {
        assert!(
            (got - want).abs() <= tol,
            "png box {:?} vs svg box {:?}",
            (px0, py0, px1, py1),
            (x0, y0, x1, y1)
        );
    }
    // A background option is honoured; `none` is transparent.
    let mut b = a.clone();
    b.extend(["--background", "#000000"]);
    let (_, _, px) = decode_png(&ok(&turtle(&b, &string)));
    assert_eq!(&px[..4], &[0, 0, 0, 255]);
    a.extend(["--background", "none"]);
    let (_, _, px) = decode_png(&ok(&turtle(&a, &string)));
    assert_eq!(px[3], 0);
    assert!(px.chunks(4).any(|p| p[3] > 100), "nothing drawn");
}

#[test]
fn obj_lines_faces_and_materials() {
    let obj = text(ok(&turtle(
        &["-f", "obj", "--angle", "90"],
        b"FF[+F]{.f+f+f}'F",
    )));
    let count = |p: &str| obj.lines().filter(|l| l.starts_with(p)).count();
    // FF continue one line (3 vertices); [+F] 2 vertices; polygon 3; 'F 2.
    assert_eq!(count("l "), 4, "{obj}");
    assert_eq!(count("f "), 1, "{obj}");
    assert_eq!(count("v "), 10, "{obj}");
    assert!(obj.contains("usemtl c0\n") && obj.contains("usemtl c1\n"));
    let cyl = text(ok(&turtle(&["-f", "obj", "--cylinders"], b"F!(0.5)F")));
    assert_eq!(cyl.lines().filter(|l| l.starts_with("f ")).count(), 16);
    assert_eq!(cyl.lines().filter(|l| l.starts_with("v ")).count(), 32);
    // -o x.obj writes x.mtl beside it and names it.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.obj");
    ok(&turtle(&["-o", out.to_str().unwrap()], b"F"));
    let o = std::fs::read_to_string(&out).unwrap();
    assert!(o.contains("mtllib x.mtl\n"));
    let m = std::fs::read_to_string(dir.path().join("x.mtl")).unwrap();
    assert!(m.contains("newmtl c0\nKd "));
    // A name that is not UTF-8: `mtllib` names the MTL by its bytes (it
    // used to write U+FFFD, a file that is not there).
    use std::os::unix::ffi::OsStrExt;
    let out = dir.path().join(std::ffi::OsStr::from_bytes(b"y\xff.obj"));
    let r = run_with_stdin(common::turtle().arg("-o").arg(&out), b"F".to_vec());
    ok(&r);
    let o = std::fs::read(&out).unwrap();
    assert!(o.windows(13).any(|w| w == b"mtllib y\xff.mtl"), "{o:?}");
    let mtl = dir.path().join(std::ffi::OsStr::from_bytes(b"y\xff.mtl"));
    assert!(std::fs::read_to_string(mtl).unwrap().contains("newmtl c0"));
}

#[test]
fn malformed_input_is_located_and_leaves_no_output() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.png");
    std::fs::write(&out, b"old").unwrap();
    let o = out.to_str().unwrap();
    // (Byte offsets counted by hand.)
    for (input, at, msg) in [
        (&b"FF(1,x)"[..], 5, "error: expected a number, found `x`"),
        (
            b"F(1",
            0,
            "error: parameter list not closed: `(` without `)`",
        ),
        (b"F[F]]F", 4, "error: unmatched `]`"),
        (b"{F}}", 3, "error: unmatched `}`"),
        (
            b"F(1e308)F(1e308)",
            8,
            "error: the turtle moved out of range (overflow)",
        ),
    ] {
        let r = turtle(&["-o", o], input);
        assert_eq!(r.status.code(), Some(1));
        assert_located(&r.stderr, input, at, msg);
        assert_eq!(std::fs::read(&out).unwrap(), b"old", "output clobbered");
    }
    // Lines and columns: lsgen's own, in characters (`é` is two bytes).
    let r = turtle(&["-o", o], "F(1)\n é F]".as_bytes());
    assert_eq!(r.status.code(), Some(1));
    assert_eq!(
        r.stderr,
        "lsgen-turtle: <stdin>:2:5: error: unmatched `]`\n é F]\n    ^\n"
    );
    assert_eq!(std::fs::read(&out).unwrap(), b"old", "output clobbered");
    // Bytes that are not UTF-8 are shown as U+FFFD.
    let r = turtle(&["-o", o], b"F\xffF");
    assert_eq!(r.status.code(), Some(1));
    assert_eq!(
        r.stderr,
        "lsgen-turtle: <stdin>:1:2: error: invalid UTF-8\nF\u{fffd}F\n ^\n"
    );
    assert_eq!(std::fs::read(&out).unwrap(), b"old", "output clobbered");
    let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert_eq!(names.len(), 1, "temp files left: {names:?}");
    // A file input names itself.
    let f = dir.path().join("s.txt");
    std::fs::write(&f, "F(2)F(").unwrap();
    let r = turtle(&[f.to_str().unwrap(), "-f", "segments"], b"");
    assert_eq!(r.status.code(), Some(1));
    assert!(r.stdout.is_empty() || r.stdout.starts_with(b"0 0 0 0 2 0"));
    assert_eq!(
        r.stderr,
        format!(
            "lsgen-turtle: {}:1:5: error: parameter list not closed: `(` without `)`\nF(2)F(\n    ^\n",
            f.display()
        )
    );
    // A missing input file.
    let r = turtle(&["/no/such/file", "-o", o], b"");
    assert_eq!(r.status.code(), Some(1));
    assert!(r
        .stderr
        .starts_with("lsgen-turtle: /no/such/file: error: cannot open"));
    assert_eq!(std::fs::read(&out).unwrap(), b"old");
}

#[test]
fn bad_view_settings() {
    let dir = tempfile::tempdir().unwrap();
    let ls = dir.path().join("m.ls");
    std::fs::write(&ls, "derivation length: 1\nview: step = two\naxiom: F\n").unwrap();
    let r = turtle(&["--ls", ls.to_str().unwrap()], b"F");
    assert_eq!(r.status.code(), Some(1));
    assert_eq!(
        r.stderr,
        format!("lsgen-turtle: {}:2:14: error: `two` is not a number\nview: step = two\n             ^\n", ls.display())
    );
    for args in [
        &["--view", "sideways"][..],
        &["--view", "0 100"],
        &["-f", "gif"],
        &["-o", "x.gif"],
        &["--size", "0"],
        &["--size", "8193"],
        &["--palette", "red"],
        &["--tropism", "0 1"],
        &["--width", "-1"],
        &["--no-such-flag"],
    ] {
        let r = turtle(args, b"F");
        assert_eq!(r.status.code(), Some(2), "{args:?}: {}", r.stderr);
        assert!(r.stdout.is_empty());
        assert!(r.stderr.starts_with("lsgen-turtle: "), "{args:?}");
    }
    assert!(!Path::new(ROOT).join("x.gif").exists());
    // The whole message of a bad view option; the direction is `--view`.
    for (args, message) in [
        (
            &["--view", "sideways"][..],
            "--view: a direction is `front`, `side`, `top` or `AZIMUTH ELEVATION` in degrees",
        ),
        (
            &["--view", "0 100"],
            "--view: the elevation is between -90 and 90",
        ),
        (&["--width=-1"], "--width: must not be negative"),
        // Written apart, a negative number is the option's value too (it
        // was clap's "unexpected argument '-1'", as for no other number).
        (&["--width", "-1"], "--width: must not be negative"),
        (
            &["--width-scale", "-2"],
            "--width-scale: must not be negative",
        ),
        (
            &["--palette", "red"],
            "--palette: `red` is not a colour `#rrggbb`",
        ),
    ] {
        let r = turtle(args, b"F");
        assert_eq!(
            r.stderr,
            format!("lsgen-turtle: error: {message}\n"),
            "{args:?}"
        );
    }
}

#[test]
fn broken_pipe_is_quiet() {
    // A reader that stops after a few bytes: exit 0, nothing on stderr.
    let mut c = common::spawn_with(
        common::turtle().args(["-f", "segments"]),
        Stdio::piped(),
        Stdio::piped(),
        Stdio::piped(),
    );
    let mut stdin = c.stdin.take().unwrap();
    let w = std::thread::spawn(move || {
        let chunk = "F+".repeat(1 << 16);
        for _ in 0..64 {
            if stdin.write_all(chunk.as_bytes()).is_err() {
                break;
            }
        }
    });
    let mut out = c.stdout.take().unwrap();
    let mut buf = [0u8; 10];
    out.read_exact(&mut buf).unwrap();
    drop(out);
    let mut err = String::new();
    c.stderr.take().unwrap().read_to_string(&mut err).unwrap();
    let status = c.wait().unwrap();
    w.join().unwrap();
    assert_eq!(status.code(), Some(0), "stderr: {err}");
    assert_eq!(err, "");
}

#[test]
fn every_example_draws_with_its_own_view() {
    for e in std::fs::read_dir(Path::new(ROOT).join("examples")).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_none_or(|x| x != "ls") {
            continue; // examples/embed.rs: the library example
        }
        let ls = format!("examples/{}", p.file_name().unwrap().to_str().unwrap());
        let src = std::fs::read_to_string(&p).unwrap();
        assert!(src.contains("\nview: "), "{ls} has no view settings");
        let string = derive(&["-n", "2", &ls]);
        let svg = text(ok(&turtle(&["--ls", &ls, "--size", "50"], &string)));
        assert!(svg.ends_with("</svg>\n"), "{ls}");
    }
}

#[test]
fn lsgen_skips_view_lines_anywhere_in_the_header() {
    let dir = tempfile::tempdir().unwrap();
    let ls = dir.path().join("v.ls");
    std::fs::write(
        &ls,
        "VIEW: angle = 90 /* upper case, comment after */\nderivation length: 2\n\
         view: palette = #2e7d32 #795548\nproductions:\n  view: step = 2\nF -> F+F\n\
         view: direction = 30 20\nhomomorphism:\nview: width = 0.5\naxiom: F\n",
    )
    .unwrap();
    // Hand derivation: F -> F+F -> F+F+F+F.
    assert_eq!(derive(&[ls.to_str().unwrap()]), b"F+F+F+F\n");
    let r = run(lsgen().arg("--check").arg(&ls));
    assert_eq!(r.ok(), "");
}

/// lsgen-turtle under `sh -c 'SETUP; exec lsgen-turtle ARGS...'`, run in
/// `dir`.
fn turtle_under_sh(setup: &str, dir: &Path) -> std::process::Command {
    let mut c = common::command("sh");
    c.arg("-c")
        .arg(format!("{setup}; exec \"$0\" \"$@\""))
        .arg(common::TURTLE)
        .current_dir(dir);
    c
}

#[test]
fn a_stream_named_as_the_input_is_read_once_and_spooled() {
    // The reference: the same string on standard input.
    let want = ok(&turtle(&["-f", "svg"], b"F+F"));
    assert!(text(want.clone()).contains("<line") || want.len() > 300);
    // /dev/stdin is a pipe here: opened again, it would be empty.
    let got = ok(&turtle(&["-f", "svg", "/dev/stdin"], b"F+F"));
    assert_eq!(text(got), text(want.clone()));
    // A named FIFO: reading it twice would block for ever.
    let dir = tempfile::tempdir().unwrap();
    let r = common::run_within(
        turtle_under_sh("mkfifo f && (printf 'F+F' > f &)", dir.path()).args(["-f", "svg", "f"]),
        std::time::Duration::from_secs(20),
    );
    r.assert_no_crash();
    assert_eq!(text(ok(&r)), text(want));
}

#[test]
fn obj_materials_only_beside_a_regular_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Streams: no MTL anywhere, no mtllib line. (/dev/*.mtl are only
    // checked when absent before: another run could have left one.)
    let stray = ["/dev/stdout.mtl", "/dev/null.mtl"].map(|p| Path::new(p).exists());
    let r = run_with_stdin(
        common::turtle().args(["-f", "obj"]).current_dir(d),
        b"F".to_vec(),
    );
    assert!(!text(ok(&r)).contains("mtllib"));
    let r = run_with_stdin(
        common::turtle()
            .args(["-f", "obj", "-o", "/dev/stdout"])
            .current_dir(d),
        b"F".to_vec(),
    );
    assert!(!text(ok(&r)).contains("mtllib"));
    assert!(stray[0] || !Path::new("/dev/stdout.mtl").exists());
    let r = run_with_stdin(
        common::turtle()
            .args(["-f", "obj", "-o", "/dev/null"])
            .current_dir(d),
        b"F".to_vec(),
    );
    ok(&r);
    assert!(stray[1] || !Path::new("/dev/null.mtl").exists());
    assert_eq!(common::listing(d).len(), 0, "{:?}", common::listing(d));
    // A link: both files beside its target, named after it.
    std::fs::create_dir(d.join("sub")).unwrap();
    std::fs::write(d.join("sub/r2.obj"), "old").unwrap();
    std::os::unix::fs::symlink("sub/r2.obj", d.join("l2.obj")).unwrap();
    let r = run_with_stdin(
        common::turtle().args(["-o", "l2.obj"]).current_dir(d),
        b"F".to_vec(),
    );
    ok(&r);
    assert!(!d.join("l2.mtl").exists());
    let obj = std::fs::read_to_string(d.join("sub/r2.obj")).unwrap();
    assert!(obj.contains("mtllib r2.mtl\n"), "{obj}");
    assert!(std::fs::read_to_string(d.join("sub/r2.mtl"))
        .unwrap()
        .contains("newmtl c0"));
    common::assert_listing(d, &["l2.obj", "sub"]);
    // OBJ to a name ending in .mtl: the OBJ, no MTL over it.
    let r = run_with_stdin(
        common::turtle()
            .args(["-f", "obj", "-o", "x.mtl"])
            .current_dir(d),
        b"F".to_vec(),
    );
    ok(&r);
    let obj = std::fs::read_to_string(d.join("x.mtl")).unwrap();
    assert!(obj.contains("\nl ") && !obj.contains("mtllib"), "{obj}");
}

#[test]
fn closed_full_or_limited_output_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // `>&-`: the picture would be lost; lsgen's rule, exit 1 with a message.
    let r = run(turtle_under_sh("printf F+F >in; exec <in >&-", d).args(["-f", "svg"]));
    r.assert_no_crash();
    assert_eq!(r.code(), Some(1), "{}", r.stderr);
    assert!(
        r.stderr
            .starts_with("lsgen-turtle: standard output: error: cannot write: Bad file descriptor (closed at startup)"),
        "{}",
        r.stderr
    );
    // --version and --help to a full device.
    for flag in ["--version", "--help"] {
        let r = run(turtle_under_sh("exec >/dev/full", d).arg(flag));
        r.assert_no_crash();
        assert_eq!(r.code(), Some(1), "{flag}: {}", r.stderr);
        assert!(r.stderr.contains("No space left"), "{flag}: {}", r.stderr);
    }
    // `ulimit -f`: not killed by SIGXFSZ, EFBIG reported, no partial file.
    let r = run(turtle_under_sh(
        "awk 'BEGIN{for(i=0;i<20000;i++) printf \"F+\"}' >in; ulimit -f 1; exec <in",
        d,
    )
    .args(["-f", "segments", "-o", "out.txt"]));
    r.assert_no_crash();
    assert_eq!(r.code(), Some(1), "{}", r.stderr);
    assert!(r.stderr.contains("File too large"), "{}", r.stderr);
    assert!(!d.join("out.txt").exists());
}

#[test]
fn ls_is_read_with_lsgens_bounded_header_reader() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let limit = std::time::Duration::from_secs(60);
    // /dev/zero: NUL at once, at 1:1.
    let r = common::run_within(
        common::turtle().args(["--ls", "/dev/zero", "-f", "segments", "/dev/null"]),
        limit,
    );
    r.assert_no_crash();
    assert_eq!(r.code(), Some(1), "{}", r.stderr);
    assert!(
        r.stderr
            .starts_with("lsgen-turtle: /dev/zero:1:1: error: NUL byte"),
        "{}",
        r.stderr
    );
    // Endless view lines, an endless comment: stop at lsgen's 64 MiB.
    for feed in ["yes 'view: angle = 3'", "(echo '/*'; yes aaaa)"] {
        let mut c = common::command("sh");
        c.arg("-c")
            .arg(format!("{feed} | \"$0\" \"$@\""))
            .arg(common::TURTLE)
            .args(["--ls", "/dev/stdin", "-f", "segments", "/dev/null"])
            .current_dir(d);
        let r = common::run_within(&mut c, limit);
        r.assert_no_crash();
        assert_eq!(r.code(), Some(1), "{feed}: {}", r.stderr);
        assert!(r.stderr.contains("too long (over 64 MiB)"), "{}", r.stderr);
    }
}

#[test]
fn view_lines_are_keywords_for_lsgen_and_the_turtle_alike() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A byte-order mark, a comment before `view:`.
    let ls = common::write(
        d,
        "v.ls",
        "\u{feff}view: angle = 90\n/* c */ view: step = 2\naxiom: F\n",
    );
    let ls = ls.to_str().unwrap();
    assert_eq!(derive(&[ls]), b"F\n");
    // Hand derivation: + turns left by 90 degrees, F steps 2 along -X.
    let got = text(ok(&turtle(&["--ls", ls, "-f", "segments"], b"+F")));
    same_segments(&got, "0 0 0 -2 0 0 1 0\n", "view lines");
    // An invalid one is an error for both, at the same place.
    let bad = common::write(d, "b.ls", "/* c */ view: angel = 3\naxiom: F\n");
    let bad = bad.to_str().unwrap();
    let r = run(lsgen().arg(bad));
    assert_eq!(r.code(), Some(1), "{}", r.stderr);
    assert!(
        r.stderr.starts_with(&format!(
            "lsgen: {bad}:1:15: error: unknown view setting `angel`"
        )),
        "{}",
        r.stderr
    );
    let r = turtle(&["--ls", bad, "-f", "segments"], b"F");
    assert_eq!(r.code(), Some(1), "{}", r.stderr);
    assert!(
        r.stderr.starts_with(&format!(
            "lsgen-turtle: {bad}:1:15: error: unknown view setting `angel`"
        )),
        "{}",
        r.stderr
    );
}

/// Width and height of a PNG (its IHDR chunk).
fn png_size(png: &[u8]) -> (u32, u32) {
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    assert_eq!(&png[12..16], b"IHDR");
    let be = |b: &[u8]| u32::from_be_bytes([b[0], b[1], b[2], b[3]]);
    (be(&png[16..20]), be(&png[20..24]))
}

#[test]
fn extreme_extents_are_errors_or_laid_out_within_size() {
    // Extents that overflow: an error at the module that drew past the
    // range (byte offsets counted by hand), nothing written.
    for (input, at) in [
        ("@M(-1e308,0,0)F@M(1e308,0,0)F", 28),
        ("F(1e308)+(180)F(1e308)F(1e308)", 22),
    ] {
        for f in ["svg", "png"] {
            let r = turtle(&["-f", f], input.as_bytes());
            assert_eq!(r.code(), Some(1), "{input}: {}", r.stderr);
            assert!(r.stdout.is_empty(), "{input}");
            assert_located(
                &r.stderr,
                input.as_bytes(),
                at,
                "error: the drawing is too large to lay out (its extent overflows)",
            );
        }
    }
    // Degenerate (tiny) boxes: drawn, finite, within --size.
    for input in ["@o(1e-320)", "!(1e-320)F(1e-320)", "@O(1e-320)F(0)"] {
        let svg = text(ok(&turtle(&["-f", "svg"], input.as_bytes())));
        for bad in ["inf", "NaN"] {
            assert!(!svg.contains(bad), "{input}: {svg}");
        }
        let vb = svg_numbers(&svg, "viewBox");
        assert!(vb[2] <= 800.0 && vb[3] <= 800.0, "{input}: {vb:?}");
        let (w, h) = png_size(&ok(&turtle(
            &["-f", "png", "--size", "100"],
            input.as_bytes(),
        )));
        assert!(w <= 100 && h <= 100, "{input}: {w}x{h}");
    }
    // A drawing without extent (a point, nothing drawn) is a square of
    // --size with the point in its middle (it was 2 margins wide: 6 of
    // 100 pixels).
    for input in ["@o(1e-320)", "f(3)", "+", "&(90)!(0)F"] {
        let png = ok(&turtle(&["-f", "png", "--size", "100"], input.as_bytes()));
        assert_eq!(png_size(&png), (100, 100), "{input}");
        let svg = text(ok(&turtle(
            &["-f", "svg", "--size", "100"],
            input.as_bytes(),
        )));
        assert_eq!(
            svg_numbers(&svg, "viewBox"),
            [0.0, 0.0, 100.0, 100.0],
            "{input}"
        );
    }
    let svg = text(ok(&turtle(
        &["-f", "svg", "--size", "100"],
        b"f(2)@o(1e-320)",
    )));
    assert!(svg.contains(r#"cx="50" cy="50""#), "{svg}");
    // A huge but finite drawing: small plain coordinates.
    let svg = text(ok(&turtle(&["-f", "svg"], b"F(1e308)+(90)F(1e307)")));
    let pts = svg_numbers(&svg, "points");
    assert!(pts.iter().all(|x| x.abs() <= 800.0), "{svg}");
}

#[test]
fn unclosed_polygons_long_numbers_and_tropism_overflow_are_named() {
    let fails = |args: &[&str], input: &[u8], want: &str| {
        let r = turtle(args, input);
        assert_eq!(r.code(), Some(1), "{want}: {}", r.stderr);
        let (at, message) = want.split_once(": ").unwrap();
        assert_located(&r.stderr, input, at.parse().unwrap(), message);
    };
    // Offsets counted by hand: the outermost unclosed `{`.
    fails(
        &["-f", "svg"],
        b"F{FF",
        "1: error: polygon not closed: `{` without `}`",
    );
    fails(
        &["-f", "segments"],
        b"F{F{F}",
        "1: error: polygon not closed: `{` without `}`",
    );
    // 2^20 vertices are kept, one more is refused at its module.
    let mut big = b"{".to_vec();
    big.extend(std::iter::repeat_n(b'.', (1 << 20) + 1));
    big.push(b'}');
    fails(
        &["-f", "segments"],
        &big,
        "1048577: error: open polygons too large (over 1048576 vertices in all)",
    );
    // 64 characters are a number; 65 are too long.
    let n64 = format!("F({})", "1".repeat(64));
    let seg = text(ok(&turtle(&["-f", "segments"], n64.as_bytes())));
    assert!(seg.starts_with("0 0 0 0 1.111111111111111"), "{seg}");
    let n65 = format!("F({})", "1".repeat(65));
    fails(
        &["-f", "segments"],
        n65.as_bytes(),
        "2: error: number too long (over 64 characters)",
    );
    fails(
        &[
            "-f",
            "segments",
            "--tropism",
            "1e308 1e308 1e308",
            "--elasticity",
            "10",
        ],
        b"FF",
        "0: error: the tropism bend overflows (elasticity × |tropism| is too large)",
    );
}

/// Out of memory is one error line and exit 1, not an abort: an 8192-pixel
/// PNG under a 150 MiB address-space cap; no output file.
#[test]
fn out_of_memory_is_an_error_not_an_abort() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let r = run(
        turtle_under_sh("printf F >in; ulimit -v 150000; exec <in", d)
            .args(["-f", "png", "--size", "8192", "-o", "big.png"]),
    );
    r.assert_no_crash();
    assert_eq!(r.code(), Some(1), "{}", r.stderr);
    assert!(
        r.stderr.starts_with("lsgen-turtle: error: out of memory ("),
        "{}",
        r.stderr
    );
    assert!(!d.join("big.png").exists());
}

#[test]
fn comma_is_the_colour_decrement_module() {
    // lsgen writes `,` outside a parameter list as a module (`F,G` is
    // three modules): the turtle reads it, as cpfg's colour decrement.
    let dir = tempfile::tempdir().unwrap();
    let ls = common::write(dir.path(), "c.ls", "axiom:\nF;F,F\n");
    let string = derive(&[ls.to_str().unwrap()]);
    assert_eq!(string, b"F;F,F\n");
    let seg = |args: &[&str], s: &[u8]| {
        let mut a = vec!["-f", "segments"];
        a.extend_from_slice(args);
        text(ok(&turtle(&a, s)))
    };
    // Colour 0, then 0 + 1, then 1 - 1 (the default increment).
    same_segments(
        &seg(&[], &string),
        "0 0 0 0 1 0 1 0\n0 1 0 0 2 0 1 1\n0 2 0 0 3 0 1 0\n",
        ",",
    );
    // With a parameter it sets the colour, also right after another
    // module's parameter list; the increment is --colour-increment.
    same_segments(
        &seg(&["--colour-increment", "2"], b",(3)F(2),(1)F;;,F"),
        "0 0 0 0 2 0 1 3\n0 2 0 0 3 0 1 1\n0 3 0 0 4 0 1 3\n",
        ",(c)",
    );
    // Still an error inside a parameter list's place: `(` and `)` alone.
    let r = turtle(&["-f", "segments"], b"F)");
    assert_eq!(r.code(), Some(1));
    assert_eq!(
        r.stderr,
        "lsgen-turtle: <stdin>:1:2: error: unexpected `)`\nF)\n ^\n"
    );
}

#[test]
fn at_takes_a_letter_only() {
    // lsgen splits `@[` into `@` and `[` (every symbol is one character),
    // and so does the turtle: `@` followed by a letter is a two-character
    // module (`@o`, `@M`, ...), followed by anything else it is `@` alone
    // (ignored) and the next character is the next module.
    let dir = tempfile::tempdir().unwrap();
    let ls = common::write(dir.path(), "a.ls", "axiom:\n@[F]F@+(90)F\n");
    let string = derive(&[ls.to_str().unwrap()]);
    assert_eq!(string, b"@[F]F@+(90)F\n");
    let seg = |s: &[u8]| text(ok(&turtle(&["-f", "segments"], s)));
    same_segments(
        &seg(&string),
        "0 0 0 0 1 0 1 0\n0 0 0 0 1 0 1 0\n0 1 0 -1 1 0 1 0\n",
        "@[ and @+",
    );
    // `@.` in a polygon records the vertex; `@@o` is `@` then `@o`;
    // `@(1)` is `@` with a parameter; `@X` is ignored, `@M` moves.
    same_segments(
        &seg(b"{@.f+(90)f+(90)f}"),
        "polygon 0 0 0 0 0 1 0 -1 1 0 -1 0 0\n",
        "@.",
    );
    same_segments(&seg(b"@@o(2)"), "dot 0 0 0 2 0\n", "@@o");
    same_segments(
        &seg(b"@(1)F@XF@M(1,2,3)F"),
        "0 0 0 0 1 0 1 0\n0 1 0 0 2 0 1 0\n1 2 3 1 3 3 1 0\n",
        "@(1) @X @M",
    );
}

#[test]
fn svg_width_zero_is_a_hairline_and_small_widths_stay_nonzero() {
    // Width 0 draws a hairline, as in PNG: one pixel whatever the zoom.
    let svg = text(ok(&turtle(&["--width", "0", "--size", "100"], b"F")));
    assert!(
        svg.contains("stroke-width=\"1\" vector-effect=\"non-scaling-stroke\" points=\""),
        "{svg}"
    );
    assert!(!svg.contains("stroke-width=\"0\""), "{svg}");
    // A width of 0.004 over a 1000-long line: the box is 1000.004 high,
    // drawn 752 pixels high (800 less two 24-pixel margins), so the
    // stroke is 0.004 * 752 / 1000.004 pixels: not 0.
    let svg = text(ok(&turtle(&[], b"!(0.004)F(1000)@o(0.004)")));
    let want = 0.004 * 752.0 / 1000.004;
    let w = svg_numbers(&svg, "stroke-width")[0];
    assert!((w - want).abs() <= want * 0.01, "{w} vs {want}: {svg}");
    assert!(!svg.contains("vector-effect"), "{svg}");
    let r = svg_numbers(&svg, "r")[0];
    assert!(
        (r - want / 2.0).abs() <= want * 0.005,
        "{r} vs {}: {svg}",
        want / 2.0
    );
}

/// A width that overflows when scaled (`!(1e308)` with `--width-scale
/// 10`) is an error at the module that draws with it, in every format:
/// `-f segments` printed `inf`, and `#` repeated past the largest number
/// too.
#[test]
fn a_width_past_the_largest_number_is_an_error_where_it_is_drawn() {
    let want = "error: the line width overflows (width × --width-scale is past the largest number)";
    for format in ["segments", "svg", "png", "obj"] {
        for (args, input, at) in [
            // (The place is the module's byte offset.)
            (&["--width-scale", "10"][..], &b"F!(1e308)F"[..], 9),
            (&["--width-scale", "10"][..], &b"!(1e308)@o"[..], 8),
            (&["--width-increment", "1e308"][..], &b"####F"[..], 4),
        ] {
            let mut a = vec!["-f", format];
            a.extend_from_slice(args);
            let r = turtle(&a, input);
            assert_eq!(r.code(), Some(1), "{format} {args:?}: {}", r.stderr);
            assert_located(&r.stderr, input, at, want);
            assert!(
                !String::from_utf8_lossy(&r.stdout).contains("inf"),
                "{format}"
            );
        }
    }
}

/// The bend is elasticity × |H × T| whatever the magnitudes: a tropism of
/// 1e200 with elasticity 1e-200 (refused as an overflow) and one of
/// 1e-200 with elasticity 1e200 (no bend at all) bend as a unit tropism
/// with elasticity 1 does.
#[test]
fn tropism_magnitudes_near_the_float_range_bend_as_their_product() {
    let points = |tropism: &str, elasticity: &str| -> Vec<f64> {
        let args = [
            "-f",
            "segments",
            "--tropism",
            tropism,
            "--elasticity",
            elasticity,
        ];
        let seg = text(ok(&turtle(&args, b"FFFF")));
        seg.split_whitespace().map(|w| w.parse().unwrap()).collect()
    };
    let unit = points("1 0 0", "0.25");
    // By hand: H starts at (0, 1, 0) and T is (1, 0, 0), |H × T| = 1, so
    // the first segment (x1 y1 z1 x2 y2 z2 width colour) is straight and
    // H turns 0.25 rad towards T after it: the second ends at x = sin 0.25.
    assert_eq!(&unit[..8], &[0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0]);
    assert!((unit[11] - 0.25f64.sin()).abs() < 1e-12, "{unit:?}");
    for (t, e) in [("1e200 0 0", "0.25e-200"), ("1e-200 0 0", "0.25e200")] {
        let got = points(t, e);
        assert_eq!(got.len(), unit.len());
        for (g, u) in got.iter().zip(&unit) {
            assert!(
                (g - u).abs() < 1e-9,
                "tropism {t} elasticity {e}: {got:?} vs {unit:?}"
            );
        }
    }
}

/// A dot of diameter 0 (or less) is one pixel wide in SVG, as in PNG and
/// as a line of width 0 is a hairline; `r="0"` drew nothing.
#[test]
fn a_dot_of_diameter_zero_is_one_pixel_in_svg_and_png() {
    for dot in [&b"F@o(0)"[..], b"F!(0)@o", b"F@O(-3)"] {
        let svg = text(ok(&turtle(&[], dot)));
        let r = svg_numbers(&svg, "r");
        assert_eq!(r, vec![0.5], "{}: {svg}", String::from_utf8_lossy(dot));
    }
    // PNG: the dot's pixel is painted (the turtle moves without drawing,
    // so the dot is all there is).
    let png = ok(&turtle(&["-f", "png", "--size", "64"], b"f(1)@o(0)"));
    let (_, _, px) = decode_png(&png);
    let background = &px[..4];
    assert!(
        px.chunks(4).any(|p| p != background),
        "the diameter-0 dot painted no pixel"
    );
}

#[test]
fn drawings_far_from_the_origin_are_fitted_to_size() {
    // By hand: the box is x in [1e12 - 900.5, 1e12 + 0.5] (901 wide) and
    // y in [1e12 - 0.5, 1e12 + 999.5] (1000 high, the strokes' half
    // width included); scale 752 / 1000 = 0.752 (800 less two margins
    // of 24), width ceil(901 * 0.752 + 48) = 726; a point (x, y) is at
    // ((x - min x) * 0.752 + 24, (max y - y) * 0.752 + 24).
    let svg = text(ok(&turtle(&[], b"@M(1e12,1e12,0)F(999)+(90)F(900)")));
    assert!(svg.contains(" viewBox=\"0 0 726 800\""), "{svg}");
    assert!(
        svg.contains(" stroke-width=\"0.752\" points=\"701.18,775.62 701.18,24.38 24.38,24.38\""),
        "{svg}"
    );
    // x in [1e10 - 0.5, 1e10 + 0.5], y in [-0.5, 5.5]: scale 752 / 6.
    let svg = text(ok(&turtle(&[], b"@M(1e10,0,0)F(5)")));
    assert!(svg.contains(" viewBox=\"0 0 174 800\""), "{svg}");
    assert!(
        svg.contains(" stroke-width=\"125.33\" points=\"86.67,713.33 86.67,86.67\""),
        "{svg}"
    );
    // The PNG has the same size.
    let png = ok(&turtle(&["-f", "png"], b"@M(1e10,0,0)F(5)"));
    assert_eq!(png_size(&png), (174, 800));
}

#[test]
fn obj_cylinders_never_write_non_finite_numbers() {
    let obj = |input: &[u8]| text(ok(&turtle(&["-f", "obj", "--cylinders"], input)));
    let verts = |o: &str| -> Vec<[f64; 3]> {
        o.lines()
            .filter_map(|l| l.strip_prefix("v "))
            .map(|l| {
                let v: Vec<f64> = l.split(' ').map(|x| x.parse().unwrap()).collect();
                [v[0], v[1], v[2]]
            })
            .collect()
    };
    // A segment 1e200 long: |d|² overflows, its direction does not. Two
    // rings of radius 0.5 about the Y axis, at y = 0 and y = 1e200.
    let o = obj(b"F(1e200)");
    let v = verts(&o);
    assert_eq!(v.len(), 16, "{o}");
    for (i, p) in v.iter().enumerate() {
        assert_eq!(p[1], if i < 8 { 0.0 } else { 1e200 }, "{o}");
        assert!((p[0] * p[0] + p[2] * p[2] - 0.25).abs() < 1e-12, "{o}");
    }
    // A segment 1e-320 long: |d|² underflows to 0, yet it has a
    // direction (Y): a tube too. Only a segment of length 0 has none.
    let o = obj(b"F(1e-320)");
    let v = verts(&o);
    assert_eq!(v.len(), 16, "{o}");
    assert!(
        v.iter()
            .all(|p| (p[0] * p[0] + p[2] * p[2] - 0.25).abs() < 1e-12),
        "{o}"
    );
    assert_eq!(
        obj(b"F(0)").lines().filter(|l| l.starts_with("v ")).count(),
        0
    );
    // Vertices past the largest number: the error of SVG and PNG at the
    // module (offsets by hand), exit 1, no output file.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("t.obj");
    let o = out.to_str().unwrap();
    // (A width that overflows when scaled is the width's own error.)
    let width = "the line width overflows (width × --width-scale is past the largest number)";
    let extent = "the drawing is too large to lay out (its extent overflows)";
    for (args, input, at, error) in [
        (&["--width-scale", "10"][..], &b"!(1e308)F"[..], 8, width),
        (&[][..], &b"@M(1.7e308,0,0)!(1e308)F"[..], 23, extent),
    ] {
        let mut a = vec!["--cylinders", "-o", o];
        a.extend_from_slice(args);
        let r = turtle(&a, input);
        assert_eq!(r.code(), Some(1), "{}", r.stderr);
        assert_located(&r.stderr, input, at, &format!("error: {error}"));
        common::assert_listing(dir.path(), &[]);
    }
}

#[test]
fn closed_standard_input_is_an_error() {
    // `<&-`: lsgen's rule and message, exit 1, no output file.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for file in [&[][..], &["-"]] {
        let r = run(turtle_under_sh("exec <&-", d)
            .args(["-o", "out.svg"])
            .args(file));
        r.assert_no_crash();
        assert_eq!(r.code(), Some(1), "{}", r.stderr);
        assert_eq!(
            r.stderr,
            "lsgen-turtle: standard input: error: cannot read: Bad file descriptor \
             (closed at startup)\n"
        );
        common::assert_listing(d, &[]);
    }
}

#[test]
fn closed_standard_input_named_by_a_path_is_an_error() {
    // `/dev/stdin` and `/dev/fd/0` with fd 0 closed, as the input or as
    // `--ls`: the read error of `<&-`, naming the path (they read the
    // /dev/null fd 0 holds then: an empty picture, no view settings).
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("in.txt"), "F").unwrap();
    for path in ["/dev/stdin", "/dev/fd/0"] {
        for args in [&[path][..], &["--ls", path, "in.txt"][..]] {
            let r = run(turtle_under_sh("exec <&-", d)
                .args(["-o", "out.svg"])
                .args(args));
            r.assert_no_crash();
            assert_eq!(r.code(), Some(1), "{args:?}: {}", r.stderr);
            assert_eq!(
                r.stderr,
                format!(
                    "lsgen-turtle: {path}: error: cannot read: Bad file descriptor \
                     (closed at startup)\n"
                ),
                "{args:?}"
            );
            common::assert_listing(d, &["in.txt"]);
        }
    }
}

#[test]
fn a_spool_that_cannot_be_written_is_named() {
    // Standard input is spooled for SVG's second pass; past `ulimit -f`
    // the spool's write fails: that error, not a parse error of the
    // input cut short ("polygon not closed").
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let r = run(turtle_under_sh(
        "awk 'BEGIN{printf \"{\"; for(i=0;i<200000;i++) printf \"F.\"; print \"}\"}' >in; \
         ulimit -f 200; exec <in",
        d,
    )
    .args(["-f", "svg", "-o", "out.svg"]));
    r.assert_no_crash();
    assert_eq!(r.code(), Some(1), "{}", r.stderr);
    assert_eq!(
        r.stderr,
        "lsgen-turtle: temporary file: error: cannot write: File too large \
         (past `ulimit -f`, or the file system's largest file)\n"
    );
    common::assert_listing(d, &["in"]);
}

#[test]
fn a_file_replaced_between_the_passes_is_read_as_it_was() {
    // The output is a FIFO: lsgen-turtle opens the input, then waits for
    // a reader of the FIFO, before either pass. Meanwhile the input is
    // replaced (as `lsgen -o` replaces a file, by renaming): both passes
    // must read the file that was opened, `F`.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut c = common::command("sh");
    c.arg("-c")
        .arg(
            "printf F >in.txt && mkfifo out.svg || exit 9
             \"$0\" -f svg in.txt -o out.svg & pid=$!
             n=0
             until ls -l /proc/$pid/fd 2>/dev/null | grep -q 'in\\.txt'; do
                 n=$((n+1)); [ $n -lt 2000 ] || exit 8; sleep 0.01
             done
             printf 'F(3)+F(7)' >new.txt && mv new.txt in.txt
             cat out.svg; wait $pid",
        )
        .arg(common::TURTLE)
        .current_dir(d);
    let r = run(&mut c);
    r.assert_no_crash();
    // By hand, `F`: the box is x in [-0.5, 0.5], y in [-0.5, 1.5], scale
    // 752 / 2 = 376, width ceil(376 + 48) = 424.
    let svg = text(ok(&r));
    assert!(svg.contains(" viewBox=\"0 0 424 800\""), "{svg}");
    assert!(
        svg.contains(" stroke-width=\"376\" points=\"212,588 212,212\"/>\n</g>"),
        "{svg}"
    );
}

#[test]
fn open_polygons_hold_at_most_2_20_vertices_in_all() {
    // Two nested polygons of 2^19 + 1 vertices each: each within 2^20,
    // together past it; refused at the vertex past 2^20, offset
    // 1 + 2^19 + 1 + 2^19 (counted by hand).
    let a = 1 << 19;
    let mut s = b"{".to_vec();
    s.extend(std::iter::repeat_n(b'.', a));
    s.push(b'{');
    s.extend(std::iter::repeat_n(b'.', a + 1));
    s.extend(b"}}");
    let r = turtle(&["-f", "segments"], &s);
    assert_eq!(r.code(), Some(1), "{}", r.stderr);
    assert_located(
        &r.stderr,
        &s,
        2 * a + 2,
        "error: open polygons too large (over 1048576 vertices in all)",
    );
    // 2^20 in all are kept: the outer polygon holds 2^20 - 3 when the
    // last inner one opens; a closed polygon gives its vertices back.
    let mut s = b"{".to_vec();
    s.extend(std::iter::repeat_n(b'.', a));
    s.extend(b"{...}");
    s.extend(std::iter::repeat_n(b'.', a - 3));
    s.extend(b"{...}}{...}");
    let seg = text(ok(&turtle(&["-f", "segments"], &s)));
    let firsts: Vec<usize> = seg.lines().map(|l| l.split(' ').count()).collect();
    assert_eq!(firsts, [11, 11, 2 + 3 * (2 * a - 3), 11]);
}

#[test]
fn an_obj_name_with_blanks_is_refused() {
    // `mtllib a b.mtl` names two files for OBJ readers: refused, a usage
    // error (exit 2), nothing written.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let r = run_with_stdin(
        common::turtle().args(["-o", "a b.obj"]).current_dir(d),
        b"F".to_vec(),
    );
    r.assert_no_crash();
    assert_eq!(r.code(), Some(2), "{}", r.stderr);
    assert_eq!(
        r.stderr,
        "lsgen-turtle: error: the OBJ would name its materials `mtllib a b.mtl`, but OBJ \
         readers split that line at blanks: give -o a name without blanks\n"
    );
    common::assert_listing(d, &[]);
    // To a stream (no MTL, no mtllib) the name does not matter.
    let r = run_with_stdin(
        common::turtle()
            .args(["-f", "obj", "-o", "/dev/stdout"])
            .current_dir(d),
        b"F".to_vec(),
    );
    assert!(text(ok(&r)).starts_with("# lsgen-turtle\n"));
}

/// The MTL beside an OBJ is no name the user gave: one there that is not
/// a regular file is refused before anything is drawn (a FIFO blocked the
/// run forever at its end; a directory was named as if `-o` had said it).
#[test]
fn an_mtl_that_is_not_a_file_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("z.mtl")).unwrap();
    let fifo = std::ffi::CString::new(d.join("f.mtl").to_str().unwrap()).unwrap();
    assert_eq!(unsafe { libc::mkfifo(fifo.as_ptr(), 0o600) }, 0);
    for stem in ["z", "f"] {
        let r = common::run_within(
            common::turtle()
                .args(["-o", &format!("{stem}.obj")])
                .current_dir(d)
                .stdin(std::process::Stdio::null()),
            std::time::Duration::from_secs(60),
        );
        r.assert_no_crash();
        assert_eq!(r.code(), Some(2), "{}", r.stderr);
        assert_eq!(
            r.stderr,
            format!(
                "lsgen-turtle: error: the OBJ's materials go to `{stem}.mtl` beside it, which is \
                 there and is not a regular file (a directory, a FIFO, a device): give -o another \
                 name\n"
            )
        );
        common::assert_listing(d, &["f.mtl", "z.mtl"]);
    }
}

#[test]
fn numbers_past_the_largest_are_out_of_range() {
    // Not "`inf` is not a number": a usage error naming the number.
    let out_of_range =
        |w: &str| format!("`{w}` is out of range (past the largest number, about 1.8e308)");
    for (args, w) in [
        (&["--angle", "1e400"][..], "1e400"),
        (&["--step=-1e400"], "-1e400"),
        (&["--width", "1e999"], "1e999"),
    ] {
        let r = turtle(args, b"F");
        assert_eq!(r.code(), Some(2), "{args:?}: {}", r.stderr);
        assert!(
            r.stderr.contains(&out_of_range(w)),
            "{args:?}: {}",
            r.stderr
        );
    }
    let r = turtle(&["--tropism", "0 1e400 0"], b"F");
    assert_eq!(r.code(), Some(2), "{}", r.stderr);
    assert_eq!(
        r.stderr,
        format!(
            "lsgen-turtle: error: --tropism: {}\n",
            out_of_range("1e400")
        )
    );
    // `inf` and `nan` are no numbers, quoted as given (`nan` was quoted
    // as `NaN`); a leading `+` is taken.
    for w in ["inf", "-inf", "nan", "NaN", "x", "1,5"] {
        let r = turtle(&["--angle", w], b"F");
        assert_eq!(r.code(), Some(2), "{w}: {}", r.stderr);
        assert!(
            r.stderr.starts_with(&format!(
                "lsgen-turtle: error: invalid value '{w}' for '--angle <ANGLE>': `{w}` is not a number\n"
            )),
            "{w}: {}",
            r.stderr
        );
    }
    let r = turtle(&["--angle", "+90", "-f", "segments"], b"F+F");
    assert_eq!(r.code(), Some(0), "{}", r.stderr);
}

/// cpfg's own files (`--cpfg-view`, `--colormap`, `--materials`).
mod cpfg_files {
    use super::*;

    fn write(dir: &Path, name: &str, data: &[u8]) -> String {
        let p = dir.join(name);
        std::fs::write(&p, data).unwrap();
        p.to_str().unwrap().to_string()
    }

    #[test]
    fn a_view_file_draws_as_its_ls_twin() {
        // tests/turtle/cpfg_bend.v says in cpfg's syntax (preprocessor,
        // comments, labels lsgen-turtle passes over) what cpfg_bend.ls
        // says in `view:` lines: the reference turtle's segments.
        let string = derive(&["-n", "4", "tests/turtle/cpfg_bend.ls"]);
        let got = text(ok(&turtle(
            &["--cpfg-view", "tests/turtle/cpfg_bend.v", "-f", "segments"],
            &string,
        )));
        let want =
            std::fs::read_to_string(Path::new(ROOT).join("tests/expected/turtle/cpfg_bend.n4.txt"))
                .unwrap();
        same_segments(&got, &want, "cpfg_bend.v");
        // Options still override the file.
        let got = text(ok(&turtle(
            &[
                "--cpfg-view",
                "tests/turtle/cpfg_bend.v",
                "--elasticity",
                "0",
                "-f",
                "segments",
            ],
            &string,
        )));
        assert_ne!(got.lines().nth(1), want.lines().nth(1));
    }

    #[test]
    fn cpfg_defaults_and_its_bend_by_hand() {
        let dir = tempfile::tempdir().unwrap();
        // An empty view file: cpfg's defaults, colour 128 (lsgen's palette
        // has 8: its last), 45 degrees, width 1.
        let v = write(dir.path(), "e.v", b"");
        let got = text(ok(&turtle(&["--cpfg-view", &v, "-f", "segments"], b"+F")));
        let s = 0.5f64.sqrt();
        same_segments(&got, &format!("0 0 0 {} {s} 0 1 128\n", -s), "defaults");
        // cpfg's bend after f too: tropism -X (towards L at the start),
        // elasticity 0.5: H turns towards L by asin(0.5) = 30 degrees.
        let v = write(
            dir.path(),
            "t.v",
            b"tropism direction: -2,0,0\ninitial elasticity: 0.5\n",
        );
        let got = text(ok(&turtle(&["--cpfg-view", &v, "-f", "segments"], b"fF")));
        same_segments(
            &got,
            "0 1 0 -0.5 1.8660254037844386 0 1 128\n",
            "bend after f",
        );
        // `_(e)` sets the elasticity; `[` keeps it.
        let got = text(ok(&turtle(
            &["--cpfg-view", &v, "-f", "segments"],
            b"[_(0)fF]fF",
        )));
        same_segments(
            &got,
            "0 1 0 0 2 0 1 128\n0 1 0 -0.5 1.8660254037844386 0 1 128\n",
            "_ in branches",
        );
    }

    /// cpfg's movements (`tropism:`, `torque:`, `@T`), worked out by hand
    /// in tests/cpfg_query.rs (`cpfg_movements_turn_the_turtle_before_each_move`):
    /// a tropism of T = (1,0,0), E = 0.5 turns H by 0.5 rad towards +x
    /// before the move, s = sin 0.5, c = cos 0.5.
    #[test]
    fn cpfg_movements_turn_before_each_move() {
        let dir = tempfile::tempdir().unwrap();
        let (s, c) = 0.5f64.sin_cos();
        let v = write(dir.path(), "m.v", b"tropism: T: 1,0,0 E: 0.5\n");
        let got = text(ok(&turtle(&["--cpfg-view", &v, "-f", "segments"], b"F")));
        same_segments(&got, &format!("0 0 0 {s} {c} 0 1 128\n"), "tropism");
        // `@Ts(1,0.5)` in a branch; its `]` gives the elasticity back (0).
        let v = write(dir.path(), "m.v", b"tropism: T: 1,0,0\n");
        let got = text(ok(&turtle(
            &["--cpfg-view", &v, "-f", "segments"],
            b"[@Ts(1,0.5)F]F",
        )));
        same_segments(
            &got,
            &format!("0 0 0 {s} {c} 0 1 128\n0 0 0 0 1 0 1 128\n"),
            "@Ts in a branch",
        );
        // An elasticity near the largest number overflows cpfg's sums (the
        // quaternion's length is infinite, its inverse 0): an error at the
        // move, not segments of length 0 (what it drew before), nor "moved
        // out of range" for a NaN frame.
        for (view, input, at) in [
            (&b"tropism: T: 1,0,0 A: 30 E: 1e308\n"[..], &b"FF"[..], 0),
            (
                b"tropism: T: 1,0,0 A: 90 E: 0.1\ntorque: T: 0,0,1 E: 1e308\n",
                b"F@Ti(1,1e308)F",
                13,
            ),
        ] {
            let v = write(dir.path(), "big.v", view);
            let r = turtle(&["--cpfg-view", &v, "-f", "segments"], input);
            assert_eq!(r.code(), Some(1), "{}", r.stderr);
            assert_located(
                &r.stderr,
                input,
                at,
                "error: cpfg's tropism or torque (the view file's movements) overflows: an \
                 elasticity this large leaves the turtle no heading (cpfg's turtle becomes NaN)",
            );
        }
        // A line cpfg ignores (a zero direction) is a warning, and draws
        // nothing.
        let v = write(dir.path(), "m.v", b"tropism: T: 0,0,0 E: 1\n");
        let r = turtle(&["--cpfg-view", &v, "-f", "segments"], b"F");
        assert!(r.status.success(), "{}", r.stderr);
        same_segments(&text(r.stdout.clone()), "0 0 0 0 1 0 1 128\n", "ignored");
        let e = &r.stderr;
        assert!(
            e.contains(
                "warning: `tropism:` ignored: cpfg ignores a movement with a direction of length 0"
            ),
            "{e}"
        );
    }

    /// cpfg's `@Tp` needs no movement line (tests/cpfg_query.rs,
    /// `at_tp_and_at_tf_without_movement_lines`): after `F/(90)+(30)` it
    /// turns U back to (0, -0.5, -0.866025) (about x by 30 degrees from
    /// the `F`'s), and `&(90)` then turns H onto U: the next segment goes
    /// from (0,1,0) along (0, -0.5, -0.866025) (the reference's `?P` after
    /// it: (8.20358e-18, 0.5, -0.866025)). Without `@Tp`, U is +x.
    #[test]
    fn cpfg_at_tp_without_movement_lines() {
        let dir = tempfile::tempdir().unwrap();
        let v = write(dir.path(), "a.v", b"angle increment: 90\n");
        let got = text(ok(&turtle(
            &["--cpfg-view", &v, "-f", "segments"],
            b"F/(90)+(30)@Tp&(90)F",
        )));
        let h = 0.75f64.sqrt();
        same_segments(
            &got,
            &format!("0 0 0 0 1 0 1 128\n0 1 0 0 0.5 {} 1 128\n", -h),
            "@Tp",
        );
    }

    /// A movement line lsgen does not follow cpfg on is ignored with a
    /// warning that says so (cpfg does not crash on a hexadecimal number,
    /// nor on a line past the 254 bytes its `fgets` reads: it reads them
    /// otherwise).
    #[test]
    fn cpfg_movement_lines_not_followed() {
        let dir = tempfile::tempdir().unwrap();
        let long = format!("tropism: T: 1,0,0{}E: 0.5\n", " ".repeat(260));
        for (view, why) in [
            (
                "tropism: T: 0x1,0,0 E: 0.5\n".to_string(),
                "has a hexadecimal number",
            ),
            (long, "is longer than the 254 bytes cpfg reads of it"),
        ] {
            let v = write(dir.path(), "m.v", view.as_bytes());
            let r = turtle(&["--cpfg-view", &v, "-f", "segments"], b"F");
            assert!(r.status.success(), "{}", r.stderr);
            same_segments(&text(r.stdout.clone()), "0 0 0 0 1 0 1 128\n", why);
            let want = format!(
                "warning: `tropism:` ignored: lsgen does not follow cpfg on a movement line that {why}"
            );
            assert!(r.stderr.contains(&want), "{}", r.stderr);
            assert!(!r.stderr.contains("crashes"), "{}", r.stderr);
        }
    }

    #[test]
    fn cpfg_bend_at_a_right_angle_and_tiny_tropisms() {
        let dir = tempfile::tempdir().unwrap();
        // e (T . L) = -1 exactly: a sine of -1 is an angle (-90 degrees),
        // H turns onto -L = +X; then + turns it 45 degrees.
        let v = write(dir.path(), "r.v", b"tropism direction: 1,0,0\n");
        let got = text(ok(&turtle(
            &["--cpfg-view", &v, "-f", "segments"],
            b"_(1)F+F",
        )));
        let s = 0.5f64.sqrt();
        same_segments(
            &got,
            &format!("0 0 0 0 1 0 1 128\n0 1 0 {s} {} 0 1 128\n", 1.0 + s),
            "sine -1",
        );
        // And +1: T = -X, H turns onto L = -X, then + turns it 45 degrees.
        let v = write(dir.path(), "r.v", b"tropism direction: -1,0,0\n");
        let got = text(ok(&turtle(
            &["--cpfg-view", &v, "-f", "segments"],
            b"_(1)F+F",
        )));
        same_segments(
            &got,
            &format!("0 0 0 0 1 0 1 128\n0 1 0 {} {} 0 1 128\n", -s, 1.0 - s),
            "sine +1",
        );
        // A subnormal tropism has a direction (cpfg's model: length 1) and
        // bends by a vanishing angle (ABOP's): no NaN, no overflow.
        let got = text(ok(&turtle(
            &[
                "--tropism",
                "1e-320 0 0",
                "--tropism-model",
                "cpfg",
                "--elasticity",
                "0.5",
                "-f",
                "segments",
            ],
            b"fF",
        )));
        same_segments(
            &got,
            "0 1 0 0.5 1.8660254037844386 0 1 0\n",
            "subnormal, cpfg",
        );
        let got = text(ok(&turtle(
            &[
                "--tropism",
                "1e-320 0 0",
                "--elasticity",
                "0.5",
                "-f",
                "segments",
            ],
            b"FF",
        )));
        same_segments(
            &got,
            "0 0 0 0 1 0 1 0\n0 1 0 0 2 0 1 0\n",
            "subnormal, abop",
        );
    }

    #[test]
    fn pixel_widths_leave_the_picture_as_it_is() {
        // Widths in pixels are no part of the model's extent: a line of 40
        // pixels lies where one of 1 pixel does.
        let dir = tempfile::tempdir().unwrap();
        let points = |w: &str| {
            let v = write(
                dir.path(),
                "w.v",
                format!("initial line width: {w} pixels\n").as_bytes(),
            );
            let svg = text(ok(&turtle(
                &["--cpfg-view", &v, "--size", "100"],
                b"F(10)+F(10)",
            )));
            svg_numbers(&svg, "points")
        };
        assert_eq!(points("1"), points("40"));
    }

    #[test]
    fn pixel_widths_twist_and_colour_maps() {
        let dir = tempfile::tempdir().unwrap();
        let v = write(
            dir.path(),
            "m.v",
            b"initial line width: 3 pixels\ninitial color: 5\ntwist: 900\n",
        );
        let mut map: Vec<u8> = vec![0; 768];
        map[0..3].copy_from_slice(&[0x10, 0x20, 0x30]);
        map[15..18].copy_from_slice(&[0xaa, 0xbb, 0xcc]);
        let m = write(dir.path(), "m.map", &map);
        for size in ["100", "800"] {
            let svg = text(ok(&turtle(
                &["--cpfg-view", &v, "--colormap", &m, "--size", size],
                b"F(10)",
            )));
            // Pixels at any size, colour 5 of the map, its entry 0 behind.
            assert!(
                svg.contains(
                    "<polyline stroke=\"#aabbcc\" stroke-width=\"3\" vector-effect=\"non-scaling-stroke\""
                ),
                "{svg}"
            );
            assert!(svg.contains("fill=\"#102030\""), "{svg}");
            // twist 900 (90 degrees): the picture turns clockwise, the
            // heading (up) points right.
            let p = svg_numbers(&svg, "points");
            assert!(p[2] > p[0] && (p[3] - p[1]).abs() < 1e-9, "{p:?}");
        }
        // A polygon line scales with the picture.
        let v2 = write(dir.path(), "p.v", b"initial line width: 0.5\n");
        let svg = text(ok(&turtle(
            &["--cpfg-view", &v2, "--size", "200"],
            b"F(10)",
        )));
        assert!(!svg.contains("non-scaling"), "{svg}");
        // Materials: the diffuse colour; the background material 0's
        // emissive one; an index without a record is white.
        let mut mat = vec![5u8, 0, 1, 1, 1, 0x12, 0x34, 0x56, 0, 0, 0, 0, 0, 0, 0];
        mat.extend([0u8, 0, 0, 0, 0, 9, 9, 9, 0x0a, 0x0b, 0x0c, 0, 0, 0, 0]);
        let mt = write(dir.path(), "m.mat", &mat);
        let svg = text(ok(&turtle(
            &["--cpfg-view", &v, "--materials", &mt],
            b"F;F",
        )));
        assert!(svg.contains("stroke=\"#123456\""), "{svg}");
        assert!(svg.contains("stroke=\"#ffffff\""), "{svg}");
        assert!(svg.contains("fill=\"#0a0b0c\""), "{svg}");
    }

    #[test]
    fn the_cpfg_example_weeps() {
        // README's pipe: examples/cpfg/weeping.l with its view file and
        // colour map, quietly.
        let string = derive(&["examples/cpfg/weeping.l"]);
        let (v, m) = ("examples/cpfg/weeping.v", "examples/cpfg/weeping.map");
        let svg = text(ok(&turtle(&["--cpfg-view", v, "--colormap", m], &string)));
        assert!(svg.contains("fill=\"#faf8f0\""), "the map's index 0 behind");
        assert!(
            svg.contains("vector-effect=\"non-scaling-stroke\""),
            "pixel lines"
        );
        // `_` raises the elasticity branch by branch, and cpfg's tropism
        // (down) bends the deep branches over: most segments head down.
        // Without the increment, few do.
        let down = |extra: &[&str]| {
            let mut args = vec!["--cpfg-view", v, "-f", "segments"];
            args.extend_from_slice(extra);
            let segs = text(ok(&turtle(&args, &string)));
            let (mut n, mut d) = (0, 0);
            for l in segs.lines().filter(|l| !l.starts_with("polygon")) {
                let w: Vec<f64> = l.split(' ').map(|x| x.parse().unwrap()).collect();
                n += 1;
                d += usize::from(w[4] < w[1]);
            }
            d as f64 / n as f64
        };
        assert!(down(&[]) > 0.8, "{}", down(&[]));
        assert!(down(&["--elasticity-increment", "0"]) < 0.2);
    }

    #[test]
    fn bad_files_are_errors_and_unknown_labels_warnings() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out.svg");
        std::fs::write(&out, "old").unwrap();
        let o = out.to_str().unwrap();
        let v = write(dir.path(), "bad.v", b"angle factor: 8\nviewpoint: 1 2 3\n");
        let r = turtle(&["--cpfg-view", &v, "-o", o], b"F");
        assert_eq!(r.status.code(), Some(1));
        assert_eq!(
            r.stderr,
            format!(
                "lsgen-turtle: {v}:2:13: error: `viewpoint:` takes three numbers `x,y,z`\nviewpoint: 1 2 3\n            ^\n"
            )
        );
        assert_eq!(std::fs::read(&out).unwrap(), b"old");
        // A label cpfg does not know: a warning, as cpfg warns; the
        // drawing is made.
        let v = write(dir.path(), "w.v", b"angel factor: 8\n");
        let r = turtle(&["--cpfg-view", &v, "-f", "segments"], b"F");
        assert!(r.status.success(), "{}", r.stderr);
        assert_eq!(
            r.stderr,
            format!(
                "lsgen-turtle: {v}:1:1: warning: `angel factor:` is no label of cpfg's view files (as cpfg, lsgen-turtle skips the line)\nangel factor: 8\n^\n"
            )
        );
        // A file whose every line warns: its first 100 warnings, then one
        // counting the rest, at the first of them (a file of 8 million
        // such lines held 1.9 GB of warnings).
        let v = write(
            dir.path(),
            "many.v",
            "angel factor: 8\n".repeat(102).as_bytes(),
        );
        let r = turtle(&["--cpfg-view", &v, "-f", "segments"], b"F");
        assert!(r.status.success(), "{}", r.stderr);
        let lines: Vec<&str> = r.stderr.lines().collect();
        assert_eq!(lines.len(), 3 * 101, "{}", r.stderr);
        assert_eq!(
            lines[3 * 100..].join("\n"),
            format!(
                "lsgen-turtle: {v}:101:1: warning: 2 more warnings from here on not shown (a file's first 100 are)\nangel factor: 8\n^"
            )
        );
        assert!(lines[3 * 99].starts_with(&format!(
            "lsgen-turtle: {v}:100:1: warning: `angel factor:`"
        )));
        // A colour map of the wrong size; a missing file; with --ls.
        let m = write(dir.path(), "m.map", &[0; 700]);
        let r = turtle(&["--colormap", &m], b"F");
        assert_eq!(r.status.code(), Some(1));
        assert!(
            r.stderr.contains("768 bytes") && r.stderr.contains("700"),
            "{}",
            r.stderr
        );
        let r = turtle(&["--cpfg-view", "/no/such.v"], b"F");
        assert_eq!(r.status.code(), Some(1));
        assert!(
            r.stderr.starts_with("lsgen-turtle: /no/such.v: error"),
            "{}",
            r.stderr
        );
        let r = turtle(&["--cpfg-view", &v, "--ls", "examples/plant_a.ls"], b"F");
        assert_eq!(r.status.code(), Some(2));
    }
}

/// Negative numbers in every spelling the parser takes: clap's own test
/// for a negative number refused `-1e-5` and `-.5` as unknown flags.
#[test]
fn number_options_take_every_negative_spelling() {
    for (opt, v) in [
        ("--angle", "-1e-5"),
        ("--angle", "-.5"),
        ("--step", "-.5"),
        ("--elasticity", "-1e-3"),
        ("--elasticity-increment", "-.01"),
        ("--width-increment", "-2.5e-1"),
        ("--colour-increment", "-1e0"),
        ("--twist", "-.25"),
    ] {
        let r = turtle(&[opt, v, "-f", "segments"], b"F");
        ok(&r);
    }
    // `--step -.5`: the step is taken.
    let r = turtle(&["--step", "-.5", "-f", "segments"], b"F");
    assert_eq!(text(ok(&r)), "0 0 0 0 -0.5 0 1 0\n");
    // Still refused: a negative width, with the option's own message.
    let r = turtle(&["--width", "-1e-3"], b"F");
    assert_eq!(r.code(), Some(2), "{}", r.stderr);
    assert!(
        r.stderr.contains("--width: must not be negative"),
        "{}",
        r.stderr
    );
}

/// `-o` with an extension that is not UTF-8 is no format's: a usage
/// error, nothing written (it was drawn as SVG).
#[test]
fn output_extension_not_utf8_is_a_usage_error() {
    use std::os::unix::ffi::OsStrExt;
    let dir = common::tempdir();
    let out = dir.path().join(std::ffi::OsStr::from_bytes(b"x.\xff"));
    let r = run_with_stdin(common::turtle().arg("-o").arg(&out), &b"F"[..]);
    r.assert_no_crash();
    assert_eq!(r.code(), Some(2), "{}", r.stderr);
    assert!(r.stderr.contains("cannot tell the format"), "{}", r.stderr);
    assert!(!out.exists());
    // With -f the name is taken as it is.
    let r = run_with_stdin(
        common::turtle().args(["-f", "segments", "-o"]).arg(&out),
        &b"F"[..],
    );
    assert_eq!(r.code(), Some(0), "{}", r.stderr);
    assert_eq!(std::fs::read(&out).unwrap(), b"0 0 0 0 1 0 1 0\n");
}

/// A dotfile's name is its extension: `-o .txt` is segments, `.obj` OBJ
/// (both were written as SVG, as Rust's rule gives such a name no
/// extension), `.drawing` no format's; `-o .` aside.
#[test]
fn a_dotfile_name_is_its_extension() {
    let dir = common::tempdir();
    let d = dir.path();
    let run = |name: &str| {
        run_with_stdin(
            common::turtle().args(["-o", name]).current_dir(d),
            &b"F"[..],
        )
    };
    let r = run(".txt");
    assert_eq!(r.code(), Some(0), "{}", r.stderr);
    assert_eq!(std::fs::read(d.join(".txt")).unwrap(), b"0 0 0 0 1 0 1 0\n");
    let r = run(".obj");
    assert_eq!(r.code(), Some(0), "{}", r.stderr);
    let obj = std::fs::read_to_string(d.join(".obj")).unwrap();
    assert!(obj.contains("\nv ") && obj.contains("mtllib"), "{obj}");
    let r = run(".drawing");
    assert_eq!(r.code(), Some(2), "{}", r.stderr);
    assert!(
        r.stderr.contains("cannot tell the format from `.drawing`"),
        "{}",
        r.stderr
    );
    assert!(!d.join(".drawing").exists());
}
