//! The topic contract against its three renderings: the Rust types (the source), the committed
//! C header (compiled by `gcc`, whose `_Static_assert`s check every size and offset) and the
//! committed Python `ctypes` module (loaded by `python3`, which compares `ctypes.sizeof`,
//! `ctypes.alignment` and every field offset with the Rust values).
//!
//! `UPDATE_CONTRACT=1 cargo test --release -p shm_types --test contract` rewrites the generated
//! files; without it, a generated file that differs from the Rust types fails the test.

use shm_types::contract::{self, Elem, TypeLayout};
use std::path::{Path, PathBuf};
use std::process::Command;

fn crate_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn header_path() -> PathBuf {
    crate_dir().join("include/vpsom_topics.h")
}

fn python_path() -> PathBuf {
    crate_dir().join("python/vpsom_topics.py")
}

/// A fresh scratch directory for this test.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("vpsom-contract-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn check_generated(path: &Path, fresh: &str) {
    if std::env::var_os("UPDATE_CONTRACT").is_some_and(|v| v == "1") {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, fresh).unwrap();
        return;
    }
    let committed = std::fs::read_to_string(path).unwrap_or_default();
    if committed != fresh {
        let line = committed
            .lines()
            .zip(fresh.lines())
            .position(|(a, b)| a != b)
            .unwrap_or(committed.lines().count().min(fresh.lines().count()));
        panic!(
            "{} is out of date with the Rust types (first difference at line {}: committed {:?}, \
             generated {:?}); run UPDATE_CONTRACT=1 cargo test --release -p shm_types --test contract",
            path.display(),
            line + 1,
            committed.lines().nth(line),
            fresh.lines().nth(line)
        );
    }
}

#[test]
fn committed_files_equal_the_generated_text() {
    check_generated(&header_path(), &contract::c_header());
    check_generated(&python_path(), &contract::python_module());
}

#[test]
fn every_type_is_covered_without_hidden_padding_and_topics_name_known_types() {
    let types = contract::types();
    let mut seen: Vec<&str> = Vec::new();
    for t in &types {
        assert_eq!(
            t.type_name,
            format!("vpsom::{}", t.name),
            "type name of {}",
            t.name
        );
        assert!(
            t.size % t.align == 0 && t.size > 0,
            "{}: size {}",
            t.name,
            t.size
        );
        let mut at = 0;
        for f in &t.fields {
            assert!(
                f.offset >= at,
                "{}.{} overlaps the field before it",
                t.name,
                f.name
            );
            assert_eq!(
                f.offset % elem_align(&types, f.elem),
                0,
                "{}.{} misaligned",
                t.name,
                f.name
            );
            assert_eq!(
                f.size,
                f.count() * elem_size(&types, f.elem),
                "{}.{} size",
                t.name,
                f.name
            );
            if let Elem::Struct(inner) = f.elem {
                assert!(
                    seen.contains(&inner),
                    "{} uses {inner} before it is described",
                    t.name
                );
            }
            at = f.offset + f.size;
        }
        // messages.rs promises that `#[repr(C)]` inserts no padding: every spare byte is a
        // `reserved` field, so C, Python and Rust agree without relying on a compiler's rules.
        assert_eq!(t.gaps(), vec![], "{} has hidden padding", t.name);
        seen.push(t.name);
    }
    for topic in contract::topics() {
        assert!(
            seen.contains(&topic.payload),
            "topic {} has unknown payload",
            topic.topic
        );
    }
    let names: Vec<&str> = contract::topics().iter().map(|t| t.topic).collect();
    for core in [
        "depth",
        "detections",
        "robot/state",
        "map",
        "nav/goal",
        "neck/goal",
    ] {
        assert!(names.contains(&core), "topic {core} missing");
    }
    assert_eq!(
        contract::service_name("main", "robot/state"),
        "vpsom/main/robot/state"
    );
}

fn elem_size(types: &[TypeLayout], e: Elem) -> usize {
    match e {
        Elem::Scalar(s) => match s {
            contract::Scalar::U8 => 1,
            contract::Scalar::U16 => 2,
            contract::Scalar::U32 | contract::Scalar::I32 | contract::Scalar::F32 => 4,
            contract::Scalar::U64 | contract::Scalar::I64 => 8,
        },
        Elem::Struct(n) => types.iter().find(|t| t.name == n).unwrap().size,
    }
}

fn elem_align(types: &[TypeLayout], e: Elem) -> usize {
    match e {
        Elem::Scalar(_) => elem_size(types, e),
        Elem::Struct(n) => types.iter().find(|t| t.name == n).unwrap().align,
    }
}

/// Runs `cmd`; `Err(output)` if it exits non-zero. Panics with a clear message if the program
/// is not installed (the contract test must not pass without checking).
fn run(cmd: &mut Command, what: &str) -> Result<String, String> {
    let out = cmd.output().unwrap_or_else(|e| {
        panic!("{what} could not be started ({e}); it is needed to check the topic contract")
    });
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    if out.status.success() {
        Ok(text)
    } else {
        Err(text)
    }
}

fn compile(compiler: &str, lang_args: &[&str], dir: &Path, header: &str) -> Result<String, String> {
    std::fs::write(dir.join("vpsom_topics.h"), header).unwrap();
    let src = dir.join("use_header.c");
    std::fs::write(
        &src,
        "#include \"vpsom_topics.h\"\nint vpsom_contract_check;\n",
    )
    .unwrap();
    run(
        Command::new(compiler)
            .args(lang_args)
            .args([
                "-Wall",
                "-Wextra",
                "-Werror",
                "-pedantic",
                "-fsyntax-only",
                "-I",
            ])
            .arg(dir)
            .arg(&src),
        compiler,
    )
}

#[test]
fn c_header_static_asserts_hold_under_gcc() {
    let dir = scratch("gcc");
    let header = std::fs::read_to_string(header_path()).expect("committed header");
    if let Err(e) = compile("gcc", &["-std=c11", "-x", "c"], &dir, &header) {
        panic!("gcc rejected {}:\n{e}", header_path().display());
    }
    // The asserts are live: a header that claims a wrong offset does not compile.
    let wrong = header.replace(
        "offsetof(vpsom_DepthFrame, width) == 24,",
        "offsetof(vpsom_DepthFrame, width) == 28,",
    );
    assert_ne!(
        wrong, header,
        "the DepthFrame.width assert is not where the test expects it"
    );
    let e =
        compile("gcc", &["-std=c11", "-x", "c"], &dir, &wrong).expect_err("wrong offset compiled");
    assert!(e.contains("vpsom_DepthFrame.width: offset"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn c_header_compiles_as_cpp17_with_iox2_type_names() {
    let dir = scratch("gxx");
    let mut header = std::fs::read_to_string(header_path()).expect("committed header");
    // C++ sees the iceoryx2 type name member on every struct.
    header.push_str(
        "static_assert(sizeof(vpsom_DepthFrame::IOX2_TYPE_NAME) > 0, \"\");\n\
         constexpr bool same(const char *a, const char *b) {\n\
         \x20   return *a == *b && (*a == 0 || same(a + 1, b + 1));\n}\n\
         static_assert(same(vpsom_RobotState::IOX2_TYPE_NAME, VPSOM_TYPE_NAME_ROBOT_STATE), \"\");\n",
    );
    if let Err(e) = compile("g++", &["-std=c++17", "-x", "c++"], &dir, &header) {
        panic!("g++ rejected {}:\n{e}", header_path().display());
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Python source that checks the generated module's ctypes layouts against `expected`
/// (`(name, type_name, size, align, [(field, offset, size)])` per type) and exits non-zero
/// with a message on the first difference.
fn python_check(types: &[TypeLayout]) -> String {
    let mut expected = String::from("EXPECTED = [\n");
    for t in types {
        let fields: Vec<String> = t
            .fields
            .iter()
            .map(|f| format!("(\"{}\", {}, {})", f.name, f.offset, f.size))
            .collect();
        expected.push_str(&format!(
            "    (\"{}\", \"{}\", {}, {}, [{}]),\n",
            t.name,
            t.type_name,
            t.size,
            t.align,
            fields.join(", ")
        ));
    }
    expected.push_str("]\n");
    let topics: Vec<String> = contract::topics()
        .iter()
        .map(|t| format!("(\"{}\", \"{}\")", t.topic, t.payload))
        .collect();
    format!(
        r#"import ctypes, sys
sys.path.insert(0, sys.argv[1])
import vpsom_topics as m
{expected}TOPICS = [{topics}]
def fail(msg):
    print("MISMATCH: " + msg)
    sys.exit(1)
for name, type_name, size, align, fields in EXPECTED:
    cls = getattr(m, name)
    if cls.type_name() != type_name: fail(f"{{name}}.type_name() = {{cls.type_name()}}")
    if ctypes.sizeof(cls) != size: fail(f"sizeof {{name}} = {{ctypes.sizeof(cls)}}, Rust {{size}}")
    if ctypes.alignment(cls) != align: fail(f"alignment {{name}} = {{ctypes.alignment(cls)}}, Rust {{align}}")
    lay = m.LAYOUT[name]
    if (lay["type_name"], lay["size"], lay["align"]) != (type_name, size, align): fail(f"LAYOUT[{{name}}]")
    if len(lay["fields"]) != len(fields): fail(f"LAYOUT[{{name}}] has {{len(lay['fields'])}} fields")
    for field, offset, fsize in fields:
        d = getattr(cls, field)
        if (d.offset, d.size) != (offset, fsize): fail(f"{{name}}.{{field}} at {{d.offset}}+{{d.size}}, Rust {{offset}}+{{fsize}}")
        if (lay["fields"][field]["offset"], lay["fields"][field]["size"]) != (offset, fsize): fail(f"LAYOUT[{{name}}].{{field}}")
for topic, payload in TOPICS:
    if m.TOPICS[topic] is not getattr(m, payload): fail(f"TOPICS[{{topic}}]")
if len(m.TOPICS) != len(TOPICS): fail("TOPICS has extra entries")
if m.service_name("main", "depth") != "vpsom/main/depth": fail("service_name")
print(f"ok: {{len(EXPECTED)}} types, {{len(TOPICS)}} topics")
"#,
        topics = topics.join(", ")
    )
}

fn python() -> String {
    std::env::var("VPSOM_PYTHON").unwrap_or_else(|_| "python3".into())
}

fn run_python_check(dir: &Path, script: &str) -> Result<String, String> {
    let path = dir.join("check.py");
    std::fs::write(&path, script).unwrap();
    run(
        Command::new(python())
            .arg(&path)
            .arg(python_path().parent().unwrap()),
        "python3 (or $VPSOM_PYTHON)",
    )
}

#[test]
fn python_ctypes_layouts_match_rust() {
    let dir = scratch("py");
    let types = contract::types();
    match run_python_check(&dir, &python_check(&types)) {
        Ok(out) => assert!(out.contains(&format!("ok: {} types", types.len())), "{out}"),
        Err(e) => panic!(
            "{} does not match the Rust layout:\n{e}",
            python_path().display()
        ),
    }
    // The check is live: a wrong expected offset is reported.
    let mut wrong = types.clone();
    let depth = wrong.iter_mut().find(|t| t.name == "DepthFrame").unwrap();
    depth.fields[1].offset += 4;
    let e = run_python_check(&dir, &python_check(&wrong)).expect_err("wrong offset passed");
    assert!(e.contains("MISMATCH: DepthFrame.width"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}
