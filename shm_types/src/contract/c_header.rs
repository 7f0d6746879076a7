//! The C/C++ header generated from the contract (`shm_types/include/vpsom_topics.h`).

use super::{Elem, TypeLayout, constants, topics, types};
use crate::COCO_CLASSES;
use std::fmt::Write;

/// `DepthFrame` → `DEPTH_FRAME`, `robot/state` → `ROBOT_STATE`.
pub(super) fn upper_snake(name: &str) -> String {
    let mut out = String::new();
    let mut prev_lower = false;
    for ch in name.chars() {
        if ch.is_ascii_uppercase() && prev_lower {
            out.push('_');
        }
        prev_lower = ch.is_ascii_lowercase() || ch.is_ascii_digit();
        if ch.is_ascii_alphanumeric() {
            out.push(ch.to_ascii_uppercase());
        } else {
            out.push('_');
        }
    }
    out
}

fn c_type(elem: Elem) -> String {
    match elem {
        Elem::Scalar(s) => s.c().to_string(),
        Elem::Struct(name) => format!("vpsom_{name}"),
    }
}

/// Name of the explicit padding member at `offset`.
pub(super) fn pad_name(offset: usize) -> String {
    format!("_pad{offset}")
}

/// One member line per field or padding gap, in offset order: `(offset, declaration, comment)`.
fn members(t: &TypeLayout) -> Vec<(usize, String, String)> {
    let mut out: Vec<(usize, String, String)> = t
        .fields
        .iter()
        .map(|f| {
            let dims: String = f.dims.iter().map(|d| format!("[{d}]")).collect();
            (
                f.offset,
                format!("{} {}{};", c_type(f.elem), f.name, dims),
                format!("offset {}, {}", f.offset, f.unit),
            )
        })
        .collect();
    for (offset, len) in t.gaps() {
        out.push((
            offset,
            format!("uint8_t {}[{len}];", pad_name(offset)),
            format!("offset {offset}, padding"),
        ));
    }
    out.sort_by_key(|m| m.0);
    out
}

pub(super) fn write_struct(h: &mut String, t: &TypeLayout) {
    let c = format!("vpsom_{}", t.name);
    let _ = writeln!(
        h,
        "/* {}: {} bytes, alignment {} */",
        t.type_name, t.size, t.align
    );
    let _ = writeln!(h, "typedef struct {c} {{");
    let _ = writeln!(h, "#ifdef __cplusplus");
    let _ = writeln!(
        h,
        "    static constexpr const char *IOX2_TYPE_NAME = \"{}\";",
        t.type_name
    );
    let _ = writeln!(h, "#endif");
    for (_, decl, comment) in members(t) {
        let _ = writeln!(h, "    {decl:<40} /* {comment} */");
    }
    let _ = writeln!(h, "}} {c};");
    let _ = writeln!(
        h,
        "VPSOM_STATIC_ASSERT(sizeof({c}) == {}, \"{c}: size\");",
        t.size
    );
    let _ = writeln!(
        h,
        "VPSOM_STATIC_ASSERT(VPSOM_ALIGNOF({c}) == {}, \"{c}: alignment\");",
        t.align
    );
    for f in &t.fields {
        let _ = writeln!(
            h,
            "VPSOM_STATIC_ASSERT(offsetof({c}, {}) == {}, \"{c}.{}: offset\");",
            f.name, f.offset, f.name
        );
    }
    let _ = writeln!(h);
}

/// The text of `shm_types/include/vpsom_topics.h`.
pub fn c_header() -> String {
    let mut h = String::new();
    h.push_str(
        "/* vpsom_topics.h: the vpsom-rt topic contract, for C11 and C++17 publishers and\n\
         \x20* subscribers of a run's iceoryx2 (0.10) publish-subscribe services.\n\
         \x20*\n\
         \x20* GENERATED from the Rust types by shm_types/src/contract; do not edit. Regenerate with\n\
         \x20*     UPDATE_CONTRACT=1 cargo test --release -p shm_types --test contract\n\
         \x20*\n\
         \x20* A service is VPSOM_SERVICE(namespace, VPSOM_TOPIC_...): \"vpsom/<namespace>/<topic>\".\n\
         \x20* Its payload type details must be: variant FixedSize, type name VPSOM_TYPE_NAME_...\n\
         \x20* (C++: the struct's IOX2_TYPE_NAME), size sizeof(vpsom_...), alignment\n\
         \x20* VPSOM_ALIGNOF(vpsom_...); no user header (iceoryx2: \"()\", size 0, alignment 1).\n\
         \x20* After each send, notify the event service of the same name (subscribers block on it).\n\
         \x20* Units: m, rad, ns, mm, px; \"1\" = dimensionless; world frame x forward, y left, z up;\n\
         \x20* camera frame = OpenCV optical (x right, y down, z forward); quaternions [x, y, z, w].\n\
         \x20*/\n\
         #pragma once\n\n\
         #include <stddef.h>\n\
         #include <stdint.h>\n\n\
         #if defined(__cplusplus)\n\
         #define VPSOM_STATIC_ASSERT(cond, msg) static_assert(cond, msg)\n\
         #define VPSOM_ALIGNOF(type) alignof(type)\n\
         #else\n\
         #define VPSOM_STATIC_ASSERT(cond, msg) _Static_assert(cond, msg)\n\
         #define VPSOM_ALIGNOF(type) _Alignof(type)\n\
         #endif\n\n",
    );
    let _ = writeln!(h, "/* ---- services ---- */");
    let _ = writeln!(h, "#define VPSOM_SERVICE_ROOT \"{}\"", super::SERVICE_ROOT);
    let _ = writeln!(
        h,
        "/* Full service name; namespace and topic are string literals. */"
    );
    let _ = writeln!(
        h,
        "#define VPSOM_SERVICE(namespace, topic) VPSOM_SERVICE_ROOT \"/\" namespace \"/\" topic"
    );
    let _ = writeln!(
        h,
        "#define VPSOM_USER_HEADER_TYPE_NAME \"{}\"",
        super::USER_HEADER_TYPE_NAME
    );
    let _ = writeln!(
        h,
        "/* iceoryx2 global.root-path and global.prefix of a run: printf formats of the uid. */"
    );
    let _ = writeln!(
        h,
        "#define VPSOM_IOX2_ROOT_FMT \"{}\"",
        super::IOX2_ROOT_FMT
    );
    let _ = writeln!(
        h,
        "#define VPSOM_IOX2_PREFIX_FMT \"{}\"",
        super::IOX2_PREFIX_FMT
    );
    let all = types();
    for t in topics() {
        let layout = all.iter().find(|l| l.name == t.payload);
        let type_name = layout.map_or("?", |l| l.type_name);
        let _ = writeln!(
            h,
            "#define VPSOM_TOPIC_{:<17} \"{}\" /* vpsom_{} ({}); from {}: {} */",
            upper_snake(t.topic),
            t.topic,
            t.payload,
            type_name,
            t.producer,
            t.doc
        );
    }
    let _ = writeln!(h);
    let _ = writeln!(h, "/* ---- iceoryx2 payload type names ---- */");
    for t in &all {
        let _ = writeln!(
            h,
            "#define VPSOM_TYPE_NAME_{:<18} \"{}\"",
            upper_snake(t.name),
            t.type_name
        );
    }
    let _ = writeln!(h);
    let _ = writeln!(h, "/* ---- capacities and enum values ---- */");
    for c in constants() {
        let name = if c.group == "capacity" {
            c.name.to_string()
        } else {
            format!("{}_{}", upper_snake(c.group), c.name)
        };
        let _ = writeln!(h, "#define VPSOM_{name:<28} {}", c.value);
    }
    let _ = writeln!(
        h,
        "/* COCO class names by class id: static const char *names[] = VPSOM_COCO_CLASSES; */"
    );
    let _ = writeln!(h, "#define VPSOM_COCO_CLASSES {{ \\");
    for chunk in COCO_CLASSES.chunks(6) {
        let line: Vec<String> = chunk.iter().map(|n| format!("\"{n}\",")).collect();
        let _ = writeln!(h, "    {} \\", line.join(" "));
    }
    let _ = writeln!(h, "}}");
    let _ = writeln!(h);
    let _ = writeln!(h, "/* ---- layouts ---- */");
    for t in &all {
        write_struct(&mut h, t);
    }
    h
}
