//! Our MCAP writer against the Foxglove SDK's, on one run: file size and write
//! time (best of three), and the size with the Foxglove views as the SDK's
//! typed protobuf messages. The table of `docs/results/mcap.md`:
//!
//! ```text
//! cargo run --release -p bearing-slam-io --features sdk-bench --example mcap_writers -- RUN.mcap [S ...]
//! ```
//!
//! `RUN.mcap` holds a log and its estimate (every snapshot); each `S` is a
//! `--snapshot-every` (default: 0 and 10).

use std::collections::HashMap;
use std::error::Error;
use std::path::Path;
use std::time::Instant;

use bearing_slam_io::live::write_log_with_sdk;
use bearing_slam_io::{McapWriteOptions, read_log, write_log_with_options};
use foxglove::messages::{FrameTransform, Log, PoseInFrame, PosesInFrame, SceneUpdate};
use foxglove::{Channel, Context, Encode, PartialMetadata, RawChannel, Schema};
use serde::de::DeserializeOwned;
use serde_json::Value;

type Res<T> = Result<T, Box<dyn Error>>;

fn main() -> Res<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let input = args
        .first()
        .ok_or("usage: mcap_writers RUN.mcap [SNAPSHOT_EVERY_S ...]")?;
    let every: Vec<f64> = if args.len() > 1 {
        args[1..]
            .iter()
            .map(|a| a.parse())
            .collect::<Result<_, _>>()?
    } else {
        vec![0.0, 10.0]
    };
    let run = read_log(input)?;
    let trace = run.trace.as_ref();
    let dir = tempfile::tempdir()?;
    println!("| --snapshot-every | writer | file MB | write s (best of 3) |");
    println!("|---|---|---|---|");
    for s in every {
        let options = McapWriteOptions {
            snapshot_every_s: s,
            ..McapWriteOptions::default()
        };
        let ours = dir.path().join("ours.mcap");
        let sdk = dir.path().join("sdk.mcap");
        let t_ours = best_of_3(|| {
            write_log_with_options(&ours, &run.log, trace, options.clone())?;
            Ok(())
        })?;
        let t_sdk = best_of_3(|| {
            // The SDK refuses nothing here, but its file must be new each time.
            let _ = std::fs::remove_file(&sdk);
            write_log_with_sdk(&sdk, &run.log, trace, options.clone())?;
            Ok(())
        })?;
        let back = read_log(&sdk)?;
        if back.log != run.log {
            return Err("the SDK's file does not read back to the same log".into());
        }
        let proto = dir.path().join("proto.mcap");
        let t_proto = best_of_3(|| protobuf_views(&ours, &proto))?;
        let mb = |p: &Path| std::fs::metadata(p).map(|m| m.len() as f64 / 1e6);
        println!(
            "| {s} | ours (`mcap` crate, JSON) | {:.2} | {t_ours:.2} |",
            mb(&ours)?
        );
        println!(
            "| {s} | Foxglove SDK `McapWriter`, same JSON messages | {:.2} | {t_sdk:.2} |",
            mb(&sdk)?
        );
        println!(
            "| {s} | Foxglove SDK, views as typed protobuf (re-encoded from ours) | {:.2} | {t_proto:.2} (includes the JSON re-parse) |",
            mb(&proto)?
        );
    }
    Ok(())
}

fn best_of_3(mut f: impl FnMut() -> Res<()>) -> Res<f64> {
    let mut best = f64::INFINITY;
    for _ in 0..3 {
        let t = Instant::now();
        f()?;
        best = best.min(t.elapsed().as_secs_f64());
    }
    Ok(best)
}

/// Rewrites `src` with the SDK: the exact-data topics as the same JSON, the
/// Foxglove views as the SDK's typed messages (protobuf).
fn protobuf_views(src: &Path, dst: &Path) -> Res<()> {
    let _ = std::fs::remove_file(dst);
    let bytes = std::fs::read(src)?;
    let context = Context::new();
    let options = foxglove::McapWriteOptions::new()
        .compression(Some(foxglove::McapCompression::Zstd))
        .compression_level(9)
        .chunk_size(Some(1024 * 1024));
    let sink = foxglove::McapWriter::with_options(options)
        .context(&context)
        .create_new_buffered_file(dst)?;
    let mut typed = Typed::default();
    let mut raw: HashMap<String, std::sync::Arc<RawChannel>> = HashMap::new();
    for message in mcap::MessageStream::new(&bytes)? {
        let message = message?;
        let topic = &message.channel.topic;
        let meta = PartialMetadata::with_log_time(message.log_time);
        let schema_name = message
            .channel
            .schema
            .as_ref()
            .map_or("", |s| s.name.as_str());
        if schema_name.starts_with("foxglove.") {
            let mut v: Value = serde_json::from_slice(&message.data)?;
            enums_as_names(&mut v, schema_name);
            match schema_name {
                "foxglove.SceneUpdate" => typed.log::<SceneUpdate>(&context, topic, v, meta)?,
                "foxglove.PoseInFrame" => typed.log::<PoseInFrame>(&context, topic, v, meta)?,
                "foxglove.PosesInFrame" => typed.log::<PosesInFrame>(&context, topic, v, meta)?,
                "foxglove.FrameTransform" => {
                    typed.log::<FrameTransform>(&context, topic, v, meta)?;
                }
                "foxglove.Log" => typed.log::<Log>(&context, topic, v, meta)?,
                other => return Err(format!("no typed message for {other}").into()),
            }
        } else {
            if !raw.contains_key(topic) {
                let schema = message.channel.schema.as_ref().ok_or("a schema")?;
                let channel = context
                    .channel_builder(topic.as_str())
                    .message_encoding(message.channel.message_encoding.as_str())
                    .schema(Schema::new(
                        schema.name.as_str(),
                        schema.encoding.as_str(),
                        schema.data.to_vec(),
                    ))
                    .metadata(message.channel.metadata.clone())
                    .build_raw()?;
                raw.insert(topic.clone(), channel);
            }
            if let Some(channel) = raw.get(topic) {
                channel.log_with_meta(&message.data, meta);
            }
        }
    }
    sink.close()?;
    Ok(())
}

/// One typed channel per topic, of whichever message type it carries.
#[derive(Default)]
struct Typed {
    channels: HashMap<String, Box<dyn std::any::Any>>,
}

impl Typed {
    fn log<T: Encode + DeserializeOwned + 'static>(
        &mut self,
        context: &std::sync::Arc<Context>,
        topic: &str,
        v: Value,
        meta: PartialMetadata,
    ) -> Res<()> {
        let channel = self
            .channels
            .entry(topic.to_owned())
            .or_insert_with(|| Box::new(context.channel_builder(topic).build::<T>()));
        let channel = channel
            .downcast_ref::<Channel<T>>()
            .ok_or("one message type per topic")?;
        let msg: T = serde_json::from_value(v)?;
        channel.log_with_meta(&msg, meta);
        Ok(())
    }
}

/// The SDK's serde form names its enums; ours writes their numbers.
fn enums_as_names(v: &mut Value, schema: &str) {
    let name = |n: &Value, names: &[&str]| {
        n.as_u64()
            .and_then(|i| names.get(usize::try_from(i).ok()?))
            .map(|s| Value::String((*s).to_owned()))
    };
    if schema == "foxglove.Log"
        && let Some(s) = name(
            &v["level"],
            &["UNKNOWN", "DEBUG", "INFO", "WARNING", "ERROR", "FATAL"],
        )
    {
        v["level"] = s;
    }
    if let Some(deletions) = v.get_mut("deletions").and_then(Value::as_array_mut) {
        for d in deletions {
            if let Some(s) = name(&d["type"], &["MATCHING_ID", "ALL"]) {
                d["type"] = s;
            }
        }
    }
    if let Some(entities) = v.get_mut("entities").and_then(Value::as_array_mut) {
        for e in entities {
            if let Some(lines) = e.get_mut("lines").and_then(Value::as_array_mut) {
                for l in lines {
                    if let Some(s) = name(&l["type"], &["LINE_STRIP", "LINE_LOOP", "LINE_LIST"]) {
                        l["type"] = s;
                    }
                }
            }
        }
    }
}
