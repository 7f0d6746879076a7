//! The Python `ctypes` module generated from the contract (`shm_types/python/vpsom_topics.py`).

use super::c_header::{pad_name, upper_snake};
use super::{Elem, TypeLayout, constants, topics, types};
use crate::COCO_CLASSES;
use std::fmt::Write;

fn ctypes_type(elem: Elem, dims: &[usize]) -> String {
    let mut t = match elem {
        Elem::Scalar(s) => s.ctypes().to_string(),
        Elem::Struct(name) => name.to_string(),
    };
    for (i, d) in dims.iter().rev().enumerate() {
        t = if i == 0 {
            format!("{t} * {d}")
        } else {
            format!("({t}) * {d}")
        };
    }
    t
}

pub(super) fn write_class(p: &mut String, t: &TypeLayout) {
    let mut members: Vec<(usize, String)> = t
        .fields
        .iter()
        .map(|f| {
            (
                f.offset,
                format!(
                    "(\"{}\", {}),  # offset {}, {}",
                    f.name,
                    ctypes_type(f.elem, &f.dims),
                    f.offset,
                    f.unit
                ),
            )
        })
        .collect();
    for (offset, len) in t.gaps() {
        members.push((
            offset,
            format!(
                "(\"{}\", ctypes.c_uint8 * {len}),  # offset {offset}, padding",
                pad_name(offset)
            ),
        ));
    }
    members.sort_by_key(|m| m.0);
    let _ = writeln!(p, "class {}(ctypes.Structure):", t.name);
    let _ = writeln!(
        p,
        "    \"\"\"{}: {} bytes, alignment {}.\"\"\"\n",
        t.type_name, t.size, t.align
    );
    let _ = writeln!(p, "    _fields_ = [");
    for (_, m) in members {
        let _ = writeln!(p, "        {m}");
    }
    let _ = writeln!(p, "    ]\n");
    let _ = writeln!(p, "    @staticmethod");
    let _ = writeln!(p, "    def type_name() -> str:");
    let _ = writeln!(
        p,
        "        \"\"\"The iceoryx2 payload type name (used by `publish_subscribe`).\"\"\""
    );
    let _ = writeln!(p, "        return \"{}\"\n\n", t.type_name);
}

/// The text of `shm_types/python/vpsom_topics.py`.
pub fn python_module() -> String {
    let mut p = String::new();
    p.push_str(
        "\"\"\"vpsom-rt topic contract: ctypes layouts of a run's iceoryx2 (0.10) payloads.\n\n\
         GENERATED from the Rust types by shm_types/src/contract; do not edit. Regenerate with\n\
         \x20   UPDATE_CONTRACT=1 cargo test --release -p shm_types --test contract\n\n\
         A service is service_name(namespace, topic) = \"vpsom/<namespace>/<topic>\"; TOPICS maps\n\
         each topic to its payload class. `iceoryx2`'s `publish_subscribe(cls)` takes the type name\n\
         from `cls.type_name()` and the size and alignment from ctypes; no user header. After each\n\
         send, notify the event service of the same name (subscribers block on it). Every padding\n\
         byte is an explicit `_pad<offset>` field, so no `_pack_` is needed. LAYOUT holds the\n\
         Rust sizes, alignments and field offsets. Units: m, rad, ns, mm, px; \"1\" = dimensionless.\n\
         \"\"\"\n\n\
         # fmt: off\n\
         import ctypes\n\n\n",
    );
    let _ = writeln!(p, "SERVICE_ROOT = \"{}\"", super::SERVICE_ROOT);
    let _ = writeln!(
        p,
        "USER_HEADER_TYPE_NAME = \"{}\"\n\n",
        super::USER_HEADER_TYPE_NAME
    );
    p.push_str(
        "def service_name(namespace: str, topic: str) -> str:\n\
         \x20   \"\"\"Full iceoryx2 service name of `topic` in a run's `namespace`.\"\"\"\n\
         \x20   return f\"{SERVICE_ROOT}/{namespace}/{topic}\"\n\n\n",
    );
    let root = super::IOX2_ROOT_FMT.replace("%u", "{uid}");
    let prefix = super::IOX2_PREFIX_FMT.replace("%u", "{uid}");
    let _ = writeln!(
        p,
        "def iceoryx2_config(iox2, uid=None):\n\
         \x20   \"\"\"The iceoryx2 config a run of user `uid` (default: this process's) uses: its own\n\
         \x20   root directory and prefix (services are owner-only). Pass it to NodeBuilder.config().\"\"\"\n\
         \x20   import os\n\
         \x20   uid = os.geteuid() if uid is None else uid\n\
         \x20   c = iox2.config.default()\n\
         \x20   c.global_cfg.root_path = iox2.Path.new(f\"{root}\")\n\
         \x20   c.global_cfg.prefix = iox2.FileName.new(f\"{prefix}\")\n\
         \x20   return c\n\n"
    );
    let _ = writeln!(p, "# ---- capacities and enum values ----");
    for c in constants() {
        let name = if c.group == "capacity" {
            c.name.to_string()
        } else {
            format!("{}_{}", upper_snake(c.group), c.name)
        };
        let _ = writeln!(p, "{name} = {}", c.value);
    }
    let _ = writeln!(p, "\n# COCO class names by class id.");
    let _ = writeln!(p, "COCO_CLASSES = (");
    for chunk in COCO_CLASSES.chunks(6) {
        let line: Vec<String> = chunk.iter().map(|n| format!("\"{n}\",")).collect();
        let _ = writeln!(p, "    {}", line.join(" "));
    }
    let _ = writeln!(p, ")\n\n");
    let all = types();
    for t in &all {
        write_class(&mut p, t);
    }
    let _ = writeln!(p, "# Topic -> payload class.");
    let _ = writeln!(p, "TOPICS = {{");
    for t in topics() {
        let _ = writeln!(p, "    \"{}\": {},", t.topic, t.payload);
    }
    let _ = writeln!(p, "}}\n");
    let _ = writeln!(
        p,
        "# The Rust layout: per type, iceoryx2 type name, size, alignment and per field (offset,\n\
         # size, element type, dims, unit)."
    );
    let _ = writeln!(p, "LAYOUT = {{");
    for t in &all {
        let _ = writeln!(
            p,
            "    \"{}\": {{\"type_name\": \"{}\", \"size\": {}, \"align\": {}, \"fields\": {{",
            t.name, t.type_name, t.size, t.align
        );
        for f in &t.fields {
            let dims: Vec<String> = f.dims.iter().map(|d| d.to_string()).collect();
            let _ = writeln!(
                p,
                "        \"{}\": {{\"offset\": {}, \"size\": {}, \"type\": \"{}\", \"dims\": [{}], \"unit\": \"{}\"}},",
                f.name,
                f.offset,
                f.size,
                f.elem.rust(),
                dims.join(", "),
                f.unit
            );
        }
        let _ = writeln!(p, "    }}}},");
    }
    let _ = writeln!(p, "}}");
    p
}
