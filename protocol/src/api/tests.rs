use super::*;
use serde_json::json;

#[test]
fn methods_and_params() {
    assert_eq!(Call::parse("status", None), Ok(Call::Status));
    assert_eq!(Call::parse("motion.start", Some(json!({}))), Ok(Call::MotionStart));
    assert_eq!(Call::parse("motion.stop", Some(json!([]))), Ok(Call::MotionStop));
    let e = Call::parse("motion.begin", None).expect_err("unknown");
    assert_eq!(e.code, codes::METHOD_NOT_FOUND);
    assert!(e.message.contains("\"motion.begin\"") && e.message.contains("motion.start"), "{}", e.message);
    let e = Call::parse("motion.start", Some(json!({"now": true}))).expect_err("extra");
    assert_eq!(e.code, codes::INVALID_PARAMS);
    assert!(e.message.contains("\"now\""), "{}", e.message);

    assert_eq!(
        Call::parse("program.load", Some(json!({"path": "/a.ngc"}))),
        Ok(Call::ProgramLoad(LoadParams::Path { path: "/a.ngc".into(), open: false }))
    );
    assert_eq!(
        Call::parse("program.load", Some(json!({"text": "G1 X1", "name": "p"}))),
        Ok(Call::ProgramLoad(LoadParams::Text { text: "G1 X1".into(), name: Some("p".into()), open: false }))
    );
    for (params, param) in [
        (None, "path"),
        (Some(json!({"path": 3})), "path"),
        (Some(json!({"text": ["G1"]})), "text"),
        (Some(json!({"text": "G1", "name": 1})), "name"),
        (Some(json!({"path": "/a", "text": "G1"})), "text"),
        (Some(json!({"path": "/a", "name": "n"})), "name"),
        (Some(json!({"path": ""})), "path"),
        (Some(json!({"file": "/a"})), "file"),
    ] {
        let e = Call::parse("program.load", params.clone()).expect_err("bad load");
        assert_eq!(e.code, codes::INVALID_PARAMS, "{params:?}");
        assert_eq!(e.data.as_ref().and_then(|d| d["param"].as_str()), Some(param), "{params:?}: {e:?}");
    }
    let e = Call::parse("program.load", Some(json!(["/a"]))).expect_err("positional");
    assert!(e.message.contains("named parameters"), "{}", e.message);

    assert_eq!(
        Call::parse("feed.override", Some(json!({"factor": 0.5}))),
        Ok(Call::FeedOverride(OverrideParams { factor: 0.5 }))
    );
    assert_eq!(
        Call::parse("feed.override", Some(json!({"percent": 150}))),
        Ok(Call::FeedOverride(OverrideParams { factor: 1.5 }))
    );
    assert_eq!(
        Call::parse("feed.override", Some(json!({"factor": 0}))),
        Ok(Call::FeedOverride(OverrideParams { factor: 0.0 }))
    );
    assert_eq!(
        Call::parse("feed.override", Some(json!({"factor": 2}))),
        Ok(Call::FeedOverride(OverrideParams { factor: 2.0 }))
    );
    for (params, param) in [
        (json!({"factor": 2.01}), "factor"),
        (json!({"factor": -0.1}), "factor"),
        (json!({"factor": "0.5"}), "factor"),
        (json!({"percent": 201}), "percent"),
        (json!({"percent": null}), "percent"),
        (json!({"factor": 1, "percent": 100}), "percent"),
        (json!({"facter": 1}), "facter"),
        (json!({}), "factor"),
    ] {
        let e = Call::parse("feed.override", Some(params.clone())).expect_err("bad override");
        assert_eq!(e.code, codes::INVALID_PARAMS, "{params}");
        assert_eq!(e.data.as_ref().and_then(|d| d["param"].as_str()), Some(param), "{params}: {e:?}");
    }
}

/// The messages of refused parameters, word for word: clients and docs/control-api.md show
/// them.
#[test]
fn refusal_messages() {
    let message = |method: &str, params: Value| {
        let e = Call::parse(method, Some(params)).expect_err("refused");
        (e.message, e.data)
    };
    let load_usage = r#"{"path": "/abs/part.ngc"} or {"text": "G1 X10 F600\n", "name": "part"}"#;
    let cases = [
        (
            "program.load",
            json!({"path": 3}),
            r#"invalid params for program.load: parameter "path" must be a string, got a number"#.to_string(),
            json!({"method": "program.load", "param": "path"}),
        ),
        (
            "program.load",
            json!({"file": "/a"}),
            r#"invalid params for program.load: unknown parameter "file"; expected "path", or "text" with an optional "name"; an optional "open" (bool)"#
                .to_string(),
            json!({"method": "program.load", "param": "file"}),
        ),
        (
            "program.load",
            json!({"name": "n"}),
            format!(r#"invalid params for program.load: missing parameter "path" or "text"; expected {load_usage}"#),
            json!({"method": "program.load", "param": "path"}),
        ),
        (
            "program.load",
            json!([1]),
            format!("invalid params for program.load: program.load takes named parameters (an object) such as {load_usage}, got an array"),
            json!({"method": "program.load"}),
        ),
        (
            "feed.override",
            json!({"factor": 2.5}),
            "invalid params for feed.override: \"factor\" 2.5 is out of range 0.0 to 2.0".to_string(),
            json!({"method": "feed.override", "param": "factor"}),
        ),
        (
            "feed.override",
            json!({"percent": 250}),
            "invalid params for feed.override: \"percent\" 250 is out of range 0 to 200".to_string(),
            json!({"method": "feed.override", "param": "percent"}),
        ),
        (
            "feed.override",
            json!({"percent": null}),
            "invalid params for feed.override: parameter \"percent\" must be a number, got null".to_string(),
            json!({"method": "feed.override", "param": "percent"}),
        ),
        (
            "motion.law",
            json!({"statement": 1}),
            "invalid params for motion.law: \"statement\" must be a string".to_string(),
            json!({"method": "motion.law", "param": "statement"}),
        ),
        (
            "motion.law",
            json!({"law": "x"}),
            r#"invalid params for motion.law: unknown parameter "law"; expected {"statement": "LAW PRESET=rr7 DURATION=0.8 X=10"}"#
                .to_string(),
            json!({"method": "motion.law", "param": "law"}),
        ),
        (
            "status",
            json!({"verbose": true, "all": 1}),
            "invalid params for status: status takes no parameters, got \"all\"".to_string(),
            json!({"method": "status", "param": "all"}),
        ),
        (
            "status",
            json!([1]),
            "invalid params for status: status takes no parameters".to_string(),
            json!({"method": "status"}),
        ),
    ];
    for (method, params, want, data) in cases {
        assert_eq!(message(method, params.clone()), (want, Some(data)), "{method} {params}");
    }
}

#[test]
fn status_and_events_on_the_wire() {
    let st = Status { axes: vec!["X".into(), "Y".into()], position: vec![1.0, 2.0], ..Status::default() };
    let v = serde_json::to_value(&st).expect("ser");
    for key in [
        "state",
        "line",
        "s_mm",
        "feed_mm_s",
        "override",
        "queue_fill",
        "queue_s",
        "cycle",
        "cycles",
        "last_error",
        "program",
        "axes",
        "position",
        "drives",
    ] {
        assert!(v.get(key).is_some(), "status lacks {key}: {v}");
    }
    assert_eq!(v["state"], "idle");
    assert_eq!(v["override"], 1.0);
    assert_eq!(v["last_error"], Value::Null);
    assert_eq!(v["cycles"]["wakeup_us"]["p999"], 0.0);
    assert_eq!(serde_json::from_value::<Status>(v).expect("de"), st);
    // A newer daemon's extra members and an older one's missing members both parse.
    let st: Status = serde_json::from_str(r#"{"state":"holding","future":1}"#).expect("de");
    assert_eq!(st.state, State::Holding);
    for s in State::ALL {
        assert_eq!(serde_json::to_value(s).expect("ser"), s.as_str());
    }

    let ev = Event::LineReached { line: 12 };
    assert_eq!(
        serde_json::to_string(&ev.to_notification()).expect("ser"),
        r#"{"jsonrpc":"2.0","method":"event","params":{"event":"line_reached","line":12}}"#
    );
    let all = [
        Event::Started,
        Event::LineReached { line: 1 },
        Event::Underrun { s_mm: 2.5 },
        Event::UnderrunCleared,
        Event::Held,
        Event::Resumed,
        Event::Stopped,
        Event::Finished { duration_s: 3.0 },
        Event::Error { message: "boom".into() },
    ];
    for (ev, name) in all.iter().zip(Event::NAMES) {
        let v = serde_json::to_value(ev).expect("ser");
        assert_eq!(v["event"], name);
        assert_eq!(ev.name(), name);
        assert_eq!(&serde_json::from_value::<Event>(v).expect("de"), ev);
    }
    let n: Notification<Event> =
        serde_json::from_str(r#"{"jsonrpc":"2.0","method":"event","params":{"event":"held"}}"#).expect("de");
    assert_eq!(n.params, Event::Held);
}

#[test]
fn drive_status_on_the_wire() {
    let d = DriveStatus {
        axis: "X".into(),
        node: 1,
        state: "operation_enabled".into(),
        statusword: Some(0x1237),
        last_emcy_code: Some("0x8100".into()),
        ..DriveStatus::default()
    };
    let v = serde_json::to_value(&d).expect("ser");
    assert_eq!(
        v,
        json!({
            "axis": "X", "node": 1, "state": "operation_enabled", "statusword": 0x1237, "nmt": null,
            "position_actual": 0, "position_actual_units": 0.0, "target_position": 0, "controlword": null,
            "tpdo_count": 0, "last_tpdo_ms_ago": null, "last_heartbeat_ms_ago": null, "heartbeat_lost": false,
            "emcy_count": 0, "last_emcy_code": "0x8100", "last_emcy_text": null, "configured": false,
            "last_sdo_error": null, "homed": false,
        })
    );
    assert_eq!(serde_json::from_value::<DriveStatus>(v).expect("de"), d);
}

#[test]
fn client_side_params_round_trip() {
    for p in [
        LoadParams::Path { path: "/a".into(), open: false },
        LoadParams::Text { text: "G1".into(), name: None, open: false },
    ] {
        let v = serde_json::to_value(&p).expect("ser");
        assert_eq!(serde_json::from_value::<LoadParams>(v).expect("de"), p);
    }
    assert!(serde_json::from_value::<LoadParams>(json!({"path": "/a", "text": "G1"})).is_err());
    let o: OverrideParams = serde_json::from_value(json!({"percent": 50})).expect("de");
    assert_eq!(o, OverrideParams { factor: 0.5 });
    assert_eq!(serde_json::to_value(o).expect("ser"), json!({"factor": 0.5}));
    assert_eq!(serde_json::to_value(Method::MotionStart).expect("ser"), "motion.start");
}

#[test]
fn long_method_names_are_cut_in_messages() {
    let e = method_not_found(&"ü".repeat(1000));
    // The name is cut to 64 characters (128 bytes here); the list of valid methods follows.
    let list: usize = Method::ALL.iter().map(|m| m.name().len() + 2).sum();
    assert!(e.message.len() < 200 + list, "{}", e.message.len());
}

#[test]
fn tool_table_and_offsets_params() {
    let t = Call::parse("tools.set", Some(json!({"tools": [{"number": 3, "diameter_mm": 8.0}]}))).expect("tools.set");
    assert_eq!(
        t,
        Call::ToolsSet(ToolTable { tools: vec![Tool { number: 3, diameter_mm: 8.0, length_mm: 0.0, name: None }] })
    );
    assert_eq!(Call::parse("tools.get", None), Ok(Call::ToolsGet));
    assert_eq!(Call::parse("offsets.get", Some(json!({}))), Ok(Call::OffsetsGet));
    for (params, param) in [
        (json!({"tools": [{"number": 3}]}), "diameter_mm"),
        (json!({"tools": [{"number": 3, "diameter_mm": 1.0, "radius": 1.0}]}), "radius"),
        (json!({"tools": [{"number": 100000, "diameter_mm": 1.0}]}), "tools[0].number"),
        (json!({"tools": [{"number": 1, "diameter_mm": -1.0}]}), "tools[0].diameter_mm"),
        (json!({"tools": [{"number": 1, "diameter_mm": 1.0}, {"number": 1, "diameter_mm": 2.0}]}), "tools[1].number"),
        (json!({"tool": []}), "tool"),
    ] {
        let e = Call::parse("tools.set", Some(params.clone())).expect_err("bad tools");
        assert_eq!(e.code, codes::INVALID_PARAMS, "{params}");
        let got = e.data.as_ref().and_then(|d| d["param"].as_str()).unwrap_or_default().to_string();
        assert!(got.ends_with(param), "{params}: {e:?}");
    }
    let o = Call::parse("offsets.set", Some(json!({"offsets": {"G54": {"X": 1.5}}}))).expect("offsets.set");
    let Call::OffsetsSet(o) = o else { panic!("{o:?}") };
    assert_eq!(o.offsets["G54"]["X"], 1.5);
    let o =
        Call::parse("offsets.set", Some(json!({"offsets": {"G59.2": {"X": 5.0}}, "rotations_deg": {"G59.2": 30.0}})))
            .expect("offsets.set of G59.2 with a rotation");
    let Call::OffsetsSet(o) = o else { panic!("{o:?}") };
    assert_eq!((o.offsets["G59.2"]["X"], o.rotations_deg["G59.2"]), (5.0, 30.0));
    for (params, param) in [
        (json!({"offsets": {}}), "offsets"),
        (json!({"rotations_deg": {}}), "offsets"),
        (json!({"rotations_deg": {"G60": 1.0}}), "rotations_deg.G60"),
        (json!({"rotations_deg": {"G54": "x"}}), "G54"),
        (json!({"offsets": {"G53": {"X": 1.0}}}), "offsets.G53"),
        (json!({"offsets": {"G54": {"X": "1"}}}), "X"),
    ] {
        let e = Call::parse("offsets.set", Some(params.clone())).expect_err("bad offsets");
        assert_eq!(e.code, codes::INVALID_PARAMS, "{params}");
        let got = e.data.as_ref().and_then(|d| d["param"].as_str()).unwrap_or_default().to_string();
        assert!(got.ends_with(param), "{params}: {e:?}");
    }
}

#[test]
fn message_event_names_its_kind_text_and_line() {
    let ev = Event::Message { kind: MessageKind::Debug, text: "i=1.000000".into(), line: 4, dropped: 0 };
    assert_eq!(
        serde_json::to_string(&ev).expect("ser"),
        r#"{"event":"message","kind":"debug","text":"i=1.000000","line":4,"dropped":0}"#
    );
    assert_eq!(ev.name(), "message");
    assert!(Event::NAMES.contains(&"message"));
}
