//! `interpd can …`: commissioning of the CAN drives from the command line.
//!
//! - `interpd can sdo read NODE INDEX [SUB] [--type T]` and `interpd can sdo write NODE INDEX
//!   SUB VALUE --type T` run one SDO transfer. By default they ask the running daemon
//!   (`drives.sdo_read`/`drives.sdo_write` on its control socket), whose master owns the SDO
//!   channel to every node: a second client on the same channel would take the master's
//!   answers. With `--can IFACE` they talk to the node directly on the bus, for a bus without
//!   a daemon (CiA 301 allows one client per SDO channel: never beside a running master).
//! - `interpd can reset [NODE…]`: `drives.reset` (fault reset) through the daemon.
//! - `interpd can home`: `machine.home` (CiA 402 homing of every axis in `home_order`) through
//!   the daemon.
//!
//! A read prints the value (as `--type`, else the bytes in hex) on stdout; an SDO abort is
//! exit 1 with the node, the object and the abort code with its meaning.

use super::CliError;
use interpd_canopen::Address;
use interpd_canopen::sdo_client::{SdoClient, Step};
use interpd_protocol::api::SdoType;
use interpd_protocol::can_socket::{from_socketcan, to_socketcan};
use interpd_protocol::cia301::NodeId;
use serde_json::{Value, json};
use socketcan::{CanSocket, Socket};
use std::io::{BufRead, BufReader, Write};
use std::os::unix::net::UnixStream;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// `interpd can`.
#[derive(Debug, clap::Args)]
pub struct CanArgs {
    #[command(subcommand)]
    pub command: CanCommand,
    /// Configuration (TOML) whose `[control] socket` the daemon listens on.
    #[arg(long, global = true)]
    pub config: Option<PathBuf>,
    /// The daemon's control socket (overrides the configuration's).
    #[arg(long, global = true)]
    pub socket: Option<PathBuf>,
}

#[derive(Debug, clap::Subcommand)]
pub enum CanCommand {
    /// One SDO transfer with a drive (CiA 301).
    #[command(subcommand)]
    Sdo(SdoCommand),
    /// Fault reset (controlword bit 7) of the drives in Fault, or of the nodes given.
    Reset {
        /// Node-IDs; none: every drive in Fault.
        nodes: Vec<u8>,
    },
    /// Home every axis of `[sinks.can] home_order` (CiA 402 homing mode), one line per axis.
    Home,
}

#[derive(Debug, clap::Subcommand)]
pub enum SdoCommand {
    /// Upload (read) an object: its value on stdout.
    Read {
        #[command(flatten)]
        at: Target,
        /// How to show the bytes (bool, u8 … u64, i8 … i64, string, bytes); default: hex.
        #[arg(long = "type", value_parser = parse_type)]
        ty: Option<SdoType>,
    },
    /// Download (write) a value to an object.
    Write {
        #[command(flatten)]
        at: Target,
        /// The value: an integer (decimal or 0x hex), text for `string`, hex for `bytes`.
        #[arg(allow_hyphen_values = true)]
        value: String,
        /// The object's type (bool, u8 … u64, i8 … i64, string, bytes).
        #[arg(long = "type", value_parser = parse_type)]
        ty: SdoType,
    },
}

/// Where the transfer goes.
#[derive(Debug, clap::Args)]
pub struct Target {
    /// Node-ID 1..=127.
    #[arg(value_parser = clap::value_parser!(u8).range(1..=127))]
    node: u8,
    /// Object index, e.g. 0x6061.
    #[arg(value_parser = parse_index)]
    index: u16,
    /// Subindex (default 0).
    #[arg(default_value_t = 0)]
    sub: u8,
    /// Talk to the node directly on this CAN interface instead of through the daemon (only
    /// where no master runs on the bus).
    #[arg(long, value_name = "IFACE")]
    can: Option<String>,
    /// Direct transfers: how long the node may take for each answer, ms.
    #[arg(long, default_value_t = 1000)]
    timeout_ms: u64,
}

fn parse_type(s: &str) -> Result<SdoType, String> {
    SdoType::from_name(s).ok_or_else(|| format!("unknown type {s:?}; expected one of {}", SdoType::names()))
}

fn parse_index(s: &str) -> Result<u16, String> {
    let v = match s.strip_prefix("0x").or_else(|| s.strip_prefix("0X")) {
        Some(h) => u16::from_str_radix(h, 16),
        None => s.parse::<u16>(),
    };
    v.map_err(|_| format!("{s:?} is not an object index 0 to 0xFFFF (e.g. 0x6061)"))
}

pub fn run(args: &CanArgs) -> Result<(), CliError> {
    match &args.command {
        CanCommand::Sdo(SdoCommand::Read { at, ty }) => {
            let data = match &at.can {
                Some(iface) => direct(iface, at, None)?,
                None => {
                    let r = call(args, "drives.sdo_read", json!({"node": at.node, "index": at.index, "sub": at.sub}))?;
                    hex_bytes(r["data"].as_str().unwrap_or_default())
                }
            };
            let shown = match ty {
                Some(t) => {
                    t.decode(&data).map_err(|e| CliError::Failure(format!("node {} {}: {e}", at.node, addr(at))))?
                }
                None => Value::String(interpd_protocol::api::drives::hex(&data)),
            };
            out(&shown.as_str().map_or_else(|| shown.to_string(), str::to_string))?;
            Ok(())
        }
        CanCommand::Sdo(SdoCommand::Write { at, value, ty }) => {
            let v = Value::String(value.clone());
            let data = ty.encode(&v).map_err(|e| CliError::BadInput(format!("VALUE: {e}")))?;
            match &at.can {
                Some(iface) => {
                    direct(iface, at, Some(data))?;
                }
                None => {
                    let params =
                        json!({"node": at.node, "index": at.index, "sub": at.sub, "type": ty.name(), "value": value});
                    call(args, "drives.sdo_write", params)?;
                }
            }
            out(&format!("node {} {} = {value} ({})", at.node, addr(at), ty.name()))?;
            Ok(())
        }
        CanCommand::Home => {
            let r = call(args, "machine.home", json!({}))?;
            for a in r["axes"].as_array().cloned().unwrap_or_default() {
                out(&format!(
                    "drive {} (node {}): homed with method {} in {:.3} s, position {} ({} increments)",
                    a["axis"].as_str().unwrap_or("?"),
                    a["node"],
                    a["method"],
                    a["duration_s"].as_f64().unwrap_or(0.0),
                    a["position_units"],
                    a["position_actual"]
                ))?;
            }
            Ok(())
        }
        CanCommand::Reset { nodes } => {
            let r = call(args, "drives.reset", json!({ "nodes": nodes }))?;
            let drives = r["drives"].as_array().cloned().unwrap_or_default();
            if drives.is_empty() {
                out("no drive in Fault")?;
            }
            for d in drives {
                out(&format!(
                    "drive {} (node {}): {} -> {}",
                    d["axis"].as_str().unwrap_or("?"),
                    d["node"],
                    d["state_before"].as_str().unwrap_or("?"),
                    d["state"].as_str().unwrap_or("?")
                ))?;
            }
            Ok(())
        }
    }
}

/// One line on stdout.
fn out(line: &str) -> Result<(), CliError> {
    writeln!(std::io::stdout(), "{line}").map_err(|e| CliError::Failure(format!("cannot write to stdout: {e}")))
}

fn addr(at: &Target) -> String {
    format!("0x{:04X}:{}", at.index, at.sub)
}

fn hex_bytes(s: &str) -> Vec<u8> {
    (0..s.len() / 2).filter_map(|i| u8::from_str_radix(&s[2 * i..2 * i + 2], 16).ok()).collect()
}

/// One call on the daemon's control socket; a JSON-RPC error is exit 1 with its message.
fn call(args: &CanArgs, method: &str, params: Value) -> Result<Value, CliError> {
    let config = interpd::config::Config::load_or_default(args.config.as_deref())?;
    let path = args.socket.clone().unwrap_or_else(|| PathBuf::from(config.control.socket_path()));
    let s = UnixStream::connect(&path).map_err(|e| {
        CliError::Failure(format!(
            "cannot reach the daemon at {}: {e} (is `interpd run --can IFACE` running? --socket, or --can IFACE to \
             talk to a node directly where no daemon runs)",
            path.display()
        ))
    })?;
    let io = |e: std::io::Error| CliError::Failure(format!("control socket {}: {e}", path.display()));
    // Homing takes as long as the axes need (the daemon bounds each by homing_timeout_ms).
    let timeout = (method != "machine.home").then_some(Duration::from_secs(60));
    s.set_read_timeout(timeout).map_err(io)?;
    let mut reader = BufReader::new(s.try_clone().map_err(io)?);
    let mut writer = s;
    writeln!(writer, "{}", json!({"jsonrpc": "2.0", "id": 1, "method": method, "params": params})).map_err(io)?;
    loop {
        let mut line = String::new();
        if reader.read_line(&mut line).map_err(io)? == 0 {
            return Err(CliError::Failure(format!("the daemon closed the connection during {method}")));
        }
        let v: Value = serde_json::from_str(&line)
            .map_err(|e| CliError::Failure(format!("{method}: unreadable answer from the daemon: {e}")))?;
        if v["id"] != json!(1) {
            continue;
        }
        if let Some(e) = v.get("error") {
            return Err(CliError::Failure(format!("{method}: {}", e["message"].as_str().unwrap_or("error"))));
        }
        return Ok(v["result"].clone());
    }
}

/// One transfer directly on the bus: `data` to write, or `None` to read.
fn direct(iface: &str, at: &Target, data: Option<Vec<u8>>) -> Result<Vec<u8>, CliError> {
    let sock = CanSocket::open(iface).map_err(|e| {
        CliError::Failure(format!("cannot open CAN interface {iface}: {e} (does it exist and is it up?)"))
    })?;
    let io = |e: std::io::Error| CliError::Failure(format!("CAN interface {iface}: {e}"));
    sock.set_read_timeout(Duration::from_millis(5)).map_err(io)?;
    let node = NodeId::new(at.node).ok_or_else(|| CliError::BadInput(format!("node-ID {} is not 1..=127", at.node)))?;
    let mut client = SdoClient::new(node, at.timeout_ms * 1000);
    let t0 = Instant::now();
    let now = || t0.elapsed().as_micros() as u64;
    let a = Address::new(at.index, at.sub);
    let first = match data {
        Some(d) => client.download(a, d, now()),
        None => client.upload(a, now()),
    }
    .map_err(|e| CliError::Failure(e.to_string()))?;
    let send = |f: &interpd_protocol::cia301::Frame| -> Result<(), CliError> {
        let cf = to_socketcan(f).ok_or_else(|| CliError::Failure("cannot build the CAN frame".into()))?;
        sock.write_frame(&cf).map_err(io)
    };
    send(&first)?;
    loop {
        let step = match sock.read_frame() {
            Ok(f) => from_socketcan(&f).ok().and_then(|f| client.on_frame(&f, now())),
            Err(_) => client.poll(now()),
        };
        match step {
            None => {}
            Some(Step::Send(f)) => send(&f)?,
            Some(Step::Uploaded(d)) => return Ok(d),
            Some(Step::Downloaded) => return Ok(Vec::new()),
            Some(Step::Failed { error, abort }) => {
                if let Some(f) = abort {
                    send(&f)?;
                }
                return Err(CliError::Failure(error.to_string()));
            }
        }
    }
}
