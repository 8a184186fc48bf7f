//! The server's answers, byte for byte over plain TCP, as a static server
//! gives them: whole files and each form of range, 416, HEAD, 304 by
//! entity tag and by date, If-Range, gzip of the page's files (never of
//! the scene), a scene written again in place, 404 for anything not on
//! the site's list however the path is spelled, 4xx for malformed input
//! while it keeps serving.

mod common;

use std::io::{BufReader, Read as _, Write as _};

use common::{bundle_file, Response, Site};
use gigawalk_serve::Limits;

#[test]
fn whole_files_and_every_form_of_range() {
    let site = Site::new();
    let server = site.serve(Limits::default());
    let scene = site.scene();
    let len = scene.len();

    let whole = server.get("/scene.gwk", &[]);
    assert_eq!(whole.status, 200);
    assert_eq!(whole.header("accept-ranges"), Some("bytes"));
    assert_eq!(
        whole.header("content-type"),
        Some("application/octet-stream")
    );
    assert_eq!(whole.header("content-length"), Some(&*len.to_string()));
    assert_eq!(whole.header("cache-control"), Some("no-cache"));
    assert!(whole.header("content-range").is_none());
    assert!(whole.body == scene, "the whole scene, byte for byte");

    // (Range header, first byte, last byte)
    let cases = [
        ("bytes=0-99".to_string(), 0, 99),
        ("bytes=1000-1999".to_string(), 1000, 1999),
        (
            format!("bytes={}-{}", len - 10, len + 500),
            len - 10,
            len - 1,
        ),
        ("bytes=1500-".to_string(), 1500, len - 1),
        ("bytes=-256".to_string(), len - 256, len - 1),
        (format!("bytes=-{}", len * 3), 0, len - 1),
        ("bytes=7-7".to_string(), 7, 7),
        ("Bytes = 8-9".to_string(), 8, 9),
    ];
    for (range, a, b) in &cases {
        let r = server.get("/scene.gwk", &[&format!("Range: {range}")]);
        assert_eq!(r.status, 206, "{range}");
        assert_eq!(
            r.header("content-range"),
            Some(&*format!("bytes {a}-{b}/{len}")),
            "{range}"
        );
        assert_eq!(
            r.header("content-length"),
            Some(&*(b - a + 1).to_string()),
            "{range}"
        );
        assert!(r.body == scene[*a..=*b], "{range}: the bytes");
    }

    for range in [
        format!("bytes={len}-"),
        format!("bytes={}-{}", len + 5, len + 9),
        "bytes=-0".into(),
        "bytes=99999999999999999999999-".into(),
    ] {
        let r = server.get("/scene.gwk", &[&format!("Range: {range}")]);
        assert_eq!(r.status, 416, "{range}");
        assert_eq!(
            r.header("content-range"),
            Some(&*format!("bytes */{len}")),
            "{range}"
        );
    }

    // Several ranges, another unit, nonsense: the whole file.
    for range in ["bytes=0-9,20-29", "items=0-9", "bytes=9-2", "bytes=x-y"] {
        let r = server.get("/scene.gwk", &[&format!("Range: {range}")]);
        assert_eq!(r.status, 200, "{range}");
        assert!(r.body == scene, "{range}");
    }

    // The bundle's files and config.json, with their types.
    let types = [
        ("index.html", "text/html"),
        ("main.js", "text/javascript"),
        ("gigawalk_web.js", "text/javascript"),
        ("gigawalk_web_bg.wasm", "application/wasm"),
    ];
    for (name, ctype) in types {
        let r = server.get(&format!("/{name}"), &[]);
        assert_eq!(r.status, 200, "{name}");
        assert_eq!(r.body, bundle_file(name), "{name}");
        let got = r.header("content-type").unwrap();
        assert!(got.starts_with(ctype), "{name}: {got}");
    }
    let root = server.get("/?scene=other.gwk", &[]);
    assert_eq!(root.status, 200);
    assert_eq!(root.body, bundle_file("index.html"), "/ is index.html");
    let c = server.get("/config.json", &[]);
    assert_eq!(c.status, 200);
    assert_eq!(c.header("content-type"), Some("application/json"));
    let json: serde_json::Value = serde_json::from_slice(&c.body).unwrap();
    assert_eq!(json, serde_json::json!({ "scene": "scene.gwk" }));
    let c = server.get("/config.json", &["Range: bytes=0-0"]);
    assert_eq!((c.status, c.body.as_slice()), (206, &b"{"[..]));

    // Many requests on one connection.
    let mut conn = server.connect();
    let mut reader = BufReader::new(conn.try_clone().unwrap());
    for (range, a, b) in &cases {
        write!(
            conn,
            "GET /scene.gwk HTTP/1.1\r\nHost: x\r\nRange: {range}\r\n\r\n"
        )
        .unwrap();
        let r = Response::read(&mut reader, false);
        assert_eq!(r.status, 206);
        assert!(r.body == scene[*a..=*b], "{range} on a kept connection");
    }
}

#[test]
fn head_answers_a_gets_headers_without_its_body() {
    let site = Site::new();
    let server = site.serve(Limits::default());
    let len = site.scene().len();
    for (path, range) in [
        ("/scene.gwk", None),
        ("/scene.gwk", Some("bytes=10-19")),
        ("/index.html", None),
        ("/config.json", None),
        ("/nothing", None),
        ("/scene.gwk", Some("bytes=999999-")),
    ] {
        let headers: Vec<String> = range.iter().map(|r| format!("Range: {r}")).collect();
        let headers: Vec<&str> = headers.iter().map(String::as_str).collect();
        let get = server.get(path, &headers);
        let head = server.ask("HEAD", path, &headers);
        assert_eq!(head.status, get.status, "{path} {range:?}");
        for name in [
            "content-length",
            "content-type",
            "content-range",
            "etag",
            "last-modified",
            "accept-ranges",
        ] {
            assert_eq!(
                head.header(name),
                get.header(name),
                "{path} {range:?}: {name}"
            );
        }
    }
    let h = server.ask("HEAD", "/scene.gwk", &["Range: bytes=10-19"]);
    assert_eq!(h.status, 206);
    assert_eq!(h.header("content-length"), Some("10"));
    assert_eq!(
        h.header("content-range"),
        Some(&*format!("bytes 10-19/{len}"))
    );

    // No body came after a HEAD's head: the next answer on the
    // connection starts right after it.
    let mut conn = server.connect();
    let mut reader = BufReader::new(conn.try_clone().unwrap());
    conn.write_all(
        b"HEAD /scene.gwk HTTP/1.1\r\nHost: x\r\n\r\nGET /config.json HTTP/1.1\r\nHost: x\r\n\r\n",
    )
    .unwrap();
    assert_eq!(Response::read(&mut reader, true).status, 200);
    let next = Response::read(&mut reader, false);
    assert_eq!(next.header("content-type"), Some("application/json"));
}

#[test]
fn a_copy_the_client_holds_gets_304_until_the_file_changes() {
    let site = Site::new();
    let server = site.serve(Limits::default());
    for path in ["/scene.gwk", "/index.html", "/config.json"] {
        let first = server.get(path, &[]);
        let etag = first.header("etag").expect("an entity tag").to_string();
        let date = first.header("last-modified").expect("a date").to_string();

        let again = server.get(path, &[&format!("If-None-Match: {etag}")]);
        assert_eq!(again.status, 304, "{path}");
        assert!(again.body.is_empty());
        assert_eq!(again.header("etag"), Some(&*etag), "{path}");
        let again = server.get(path, &[&format!("If-None-Match: \"other\", {etag}")]);
        assert_eq!(again.status, 304, "{path}: one of a list");
        let again = server.get(path, &[&format!("If-Modified-Since: {date}")]);
        assert_eq!(again.status, 304, "{path}: by date");
        let head = server.ask("HEAD", path, &[&format!("If-None-Match: {etag}")]);
        assert_eq!(head.status, 304, "{path}: HEAD");

        let other = server.get(path, &["If-None-Match: \"other\""]);
        assert_eq!(other.status, 200, "{path}");
        let old = server.get(path, &["If-Modified-Since: Thu, 01 Jan 1970 00:00:00 GMT"]);
        assert_eq!(old.status, 200, "{path}");
        // The tag decides when both are sent.
        let both = server.get(
            path,
            &[
                "If-None-Match: \"other\"",
                &format!("If-Modified-Since: {date}"),
            ],
        );
        assert_eq!(both.status, 200, "{path}");
    }

    // A scene written again in place: served as it is now, under a new
    // tag, so a client's copy of the old one is not taken for it.
    let before = server.get("/scene.gwk", &[]);
    let etag = before.header("etag").unwrap().to_string();
    let new = common::scene_bytes(7000)
        .into_iter()
        .rev()
        .collect::<Vec<u8>>();
    std::fs::write(&site.scene, &new).unwrap();
    let after = server.get("/scene.gwk", &[&format!("If-None-Match: {etag}")]);
    assert_eq!(after.status, 200);
    assert!(after.body == new, "the scene as it is now");
    assert_ne!(after.header("etag"), Some(&*etag));
    let r = server.get("/scene.gwk", &["Range: bytes=-3"]);
    assert_eq!(r.body, new[new.len() - 3..]);
}

#[test]
fn if_range_applies_the_range_only_to_the_same_file() {
    let site = Site::new();
    let server = site.serve(Limits::default());
    let scene = site.scene();
    let first = server.get("/scene.gwk", &[]);
    let etag = first.header("etag").unwrap().to_string();
    assert!(!etag.starts_with("W/"), "the scene's tag is strong: {etag}");
    let date = first.header("last-modified").unwrap().to_string();
    for (if_range, ranged) in [
        (etag.clone(), true),
        (date, true),
        ("\"another\"".to_string(), false),
        (format!("W/{etag}"), false),
        ("Thu, 01 Jan 1970 00:00:00 GMT".to_string(), false),
    ] {
        let r = server.get(
            "/scene.gwk",
            &["Range: bytes=0-9", &format!("If-Range: {if_range}")],
        );
        if ranged {
            assert_eq!((r.status, &r.body[..]), (206, &scene[..10]), "{if_range}");
        } else {
            assert_eq!(r.status, 200, "{if_range}");
            assert!(r.body == scene, "{if_range}");
        }
    }
}

/// Un-gzips `bytes`.
fn gunzip(bytes: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    flate2::read::GzDecoder::new(bytes)
        .read_to_end(&mut out)
        .expect("gzip");
    out
}

#[test]
fn the_pages_files_are_gzipped_for_a_client_that_takes_it_never_the_scene() {
    let site = Site::new();
    let server = site.serve(Limits::default());
    for name in ["index.html", "main.js", "gigawalk_web_bg.wasm"] {
        let r = server.get(&format!("/{name}"), &["Accept-Encoding: gzip, deflate, br"]);
        assert_eq!(r.status, 200, "{name}");
        assert_eq!(r.header("content-encoding"), Some("gzip"), "{name}");
        assert!(
            r.header("vary")
                .is_some_and(|v| v.contains("accept-encoding")),
            "{name}: {:?}",
            r.header("vary")
        );
        let original = bundle_file(name);
        assert!(r.body.len() < original.len(), "{name}: smaller");
        assert_eq!(gunzip(&r.body), original, "{name}");
        // Without Accept-Encoding: as it is.
        let plain = server.get(&format!("/{name}"), &[]);
        assert!(plain.header("content-encoding").is_none(), "{name}");
        assert_eq!(plain.body, original);
        // A client that refuses gzip.
        let refused = server.get(&format!("/{name}"), &["Accept-Encoding: gzip;q=0"]);
        assert!(refused.header("content-encoding").is_none(), "{name}");
    }
    let scene = site.scene();
    for range in [None, Some(("bytes=100-199", 100, 199))] {
        let mut headers = vec!["Accept-Encoding: gzip".to_string()];
        if let Some((r, _, _)) = range {
            headers.push(format!("Range: {r}"));
        }
        let headers: Vec<&str> = headers.iter().map(String::as_str).collect();
        let r = server.get("/scene.gwk", &headers);
        assert!(r.header("content-encoding").is_none(), "{range:?}");
        match range {
            Some((_, a, b)) => assert!(r.status == 206 && r.body == scene[a..=b]),
            None => assert!(r.status == 200 && r.body == scene),
        }
    }
    // A range of a page's file is sent as it is, never gzipped.
    let r = server.get("/main.js", &["Accept-Encoding: gzip", "Range: bytes=0-9"]);
    assert_eq!(r.status, 206);
    assert!(r.header("content-encoding").is_none());
    assert_eq!(r.body, bundle_file("main.js")[..10]);
}

#[test]
fn nothing_off_the_list_is_served_however_it_is_spelled() {
    let site = Site::new();
    let server = site.serve(Limits::default());
    for path in [
        "/../secret.txt",
        "/..%2Fsecret.txt",
        "/%2e%2e/secret.txt",
        "/%2E%2E%2Fsecret.txt",
        "/bundle/../secret.txt",
        "/sub/x.js",
        "/sub%2Fx.js",
        "/.hidden",
        "/nothing.html",
        "/scene.gwk/",
        "/plant.gwk",
        "//etc/passwd",
        "/index.html/..",
        "/index.html%00",
        "/%69ndex.html",
        "/INDEX.HTML",
        "http://x/../secret.txt",
        "http://x/sub/x.js",
    ] {
        let r = server.get(path, &[]);
        assert_eq!(r.status, 404, "{path}");
        assert!(
            !String::from_utf8_lossy(&r.body).contains("not served"),
            "{path}"
        );
    }
    // The absolute form names a served file as the origin form does.
    let r = server.get("http://example.com/main.js", &[]);
    assert_eq!((r.status, r.body), (200, bundle_file("main.js")));
}

#[test]
fn malformed_input_gets_4xx_and_the_server_goes_on() {
    let site = Site::new();
    let server = site.serve(Limits::default());

    for method in ["POST", "PUT", "DELETE", "OPTIONS", "BREW"] {
        let p = server.ask(method, "/scene.gwk", &["Content-Length: 0"]);
        assert_eq!(p.status, 405, "{method}");
        assert_eq!(p.header("allow"), Some("GET, HEAD"), "{method}");
    }
    // A POST with a body: refused, and the connection still serves.
    let mut conn = server.connect();
    let mut reader = BufReader::new(conn.try_clone().unwrap());
    conn.write_all(
        b"POST /index.html HTTP/1.1\r\nHost: x\r\nContent-Length: 5\r\n\r\nhelloGET /config.json HTTP/1.1\r\nHost: x\r\n\r\n",
    )
    .unwrap();
    assert_eq!(Response::read(&mut reader, false).status, 405);
    assert_eq!(Response::read(&mut reader, false).status, 200);

    // Not HTTP as the server reads it: 400 (431 for an oversized head),
    // and the connection closes.
    let long_header = format!(
        "GET /index.html HTTP/1.1\r\nHost: x\r\nX-Long: {}\r\n\r\n",
        "a".repeat(200_000)
    );
    let many_headers = format!(
        "GET /index.html HTTP/1.1\r\nHost: x\r\n{}\r\n",
        (0..500)
            .map(|i| format!("X-{i}: y\r\n"))
            .collect::<String>()
    );
    let cases: Vec<(&[u8], &str)> = vec![
        (b"NONSENSE\r\n\r\n", "400"),
        (b"GET /index.html\r\n\r\n", "400"),
        (b"GET index.html HTTP/1.1\r\nHost: x\r\n\r\n", "400"),
        (b"GET /index.html HTTP/1.1 extra\r\nHost: x\r\n\r\n", "400"),
        (b"GET /index.html HTTP/1.1\r\nno colon here\r\n\r\n", "400"),
        (b"GET /index.html HTTP/1.1\r\nBad Name: x\r\n\r\n", "400"),
        (b"GET /index.html HTTP/1.1\r\n\r\n", "400"),
        (b"GET /a b HTTP/1.1\r\nHost: x\r\n\r\n", "400"),
        (b"GET /index.html HTTP/9.9\r\nHost: x\r\n\r\n", "4"),
        (b"\x01\x02\x03\r\n\r\n", "400"),
        (&[0xff; 20_000], "4"),
        (
            b"GET /index.html HTTP/1.1\r\nHost: x\r\nContent-Length: nope\r\n\r\n",
            "400",
        ),
        (long_header.as_bytes(), "431"),
        (many_headers.as_bytes(), "431"),
    ];
    for (bad, status) in cases {
        let answer = server.raw(bad);
        assert!(
            answer.starts_with(&format!("HTTP/1.1 {status}")),
            "{:?} got {answer:?}",
            String::from_utf8_lossy(&bad[..bad.len().min(60)])
        );
    }
    // A client that goes away mid-request, or sends nothing.
    let mut c = server.connect();
    c.write_all(b"GET /scene.gwk HT").unwrap();
    drop(c);
    drop(server.connect());

    let r = server.get("/scene.gwk", &["Range: bytes=0-3"]);
    assert_eq!(r.status, 206, "still serving");
    assert_eq!(r.body, site.scene()[..4]);
}
