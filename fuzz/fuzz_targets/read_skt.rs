//! TopoMender's skeleton files (`.skt`), the bytes in memory (`read_skt_bytes`; the selector
//! byte is unused). Besides "no panic": what is read holds the reader's promises (weights ≥ 0 or
//! +inf, coordinates below 2^20, at most two passes) and is the file: each record encoded again
//! gives the file's bytes, with only end-of-pass bytes between them.
#![no_main]

use std::path::Path;

use isoforge_io::read::skt::{read_skt_bytes, SktRecord, END_OF_PASS, RECORD_BYTES};
use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

fn encode(r: &SktRecord) -> Vec<u8> {
    let mut out = vec![r.type_byte()];
    out.extend(r.weight.to_le_bytes());
    for e in r.ends {
        let v = u64::from(e[2]) | u64::from(e[1]) << 20 | u64::from(e[0]) << 40;
        out.extend(v.to_le_bytes());
    }
    out
}

fuzz_target!(|data: &[u8]| {
    let Some((_, main)) = data.split_first() else { return };
    match read_skt_bytes(Path::new("f.skt"), main, &common::limits()) {
        Ok(s) => {
            assert!(s.passes <= 2, "{} passes", s.passes);
            assert_eq!(s.records.len() * RECORD_BYTES + s.passes as usize, main.len(), "bytes unaccounted for");
            let mut at = 0;
            for r in &s.records {
                assert!(r.weight >= 0.0, "weight {}", r.weight);
                assert!(r.ends.iter().flatten().all(|&c| c < 1 << 20), "ends {:?}", r.ends);
                while main[at] == END_OF_PASS {
                    at += 1;
                }
                assert_eq!(&main[at..at + RECORD_BYTES], encode(r).as_slice(), "record at byte {at}");
                at += RECORD_BYTES;
            }
            assert!(main[at..].iter().all(|&b| b == END_OF_PASS), "the file ends in end-of-pass bytes");
        }
        Err(e) => {
            let msg = e.to_string();
            assert!(msg.starts_with("f.skt: ") && !msg.contains('\n'), "message: {msg}");
        }
    }
});
