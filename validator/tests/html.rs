//! The HTML report (`ommcheck check --format html`, `--html FILE`), opened
//! in headless Chromium as a reader would open it: the page loads, every
//! picture decodes, nothing is reported on the console (a resource the
//! page's Content-Security-Policy blocks, an error), and a screenshot shows
//! the page with its pictures.
//!
//! Chromium is Debian's `chromium`, which `cargo xtask test` installs. These
//! tests skip, saying so, only on a system without apt-get, where it cannot
//! be installed that way; in CI, or where apt-get could install it, a
//! missing Chromium fails them.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// How long one Chromium run may take before the test fails (it takes
/// about a second).
const CHROMIUM_TIMEOUT: Duration = Duration::from_secs(120);

/// The blue of opaque micro-triangles in the pictures, and the red of the
/// page's error badges, as (r, g, b).
const OPAQUE_BLUE: (u8, u8, u8) = (0x2b, 0x5d, 0x9e);
const ERROR_RED: (u8, u8, u8) = (0xb0, 0x00, 0x20);

fn in_ci() -> bool {
    std::env::var("CI").is_ok_and(|v| !v.is_empty() && v != "false" && v != "0")
}

/// The Chromium executable, or None (the test skips) where none is
/// installed and none can be: no apt-get, outside CI.
fn chromium() -> Option<&'static str> {
    for name in ["chromium", "chromium-browser", "google-chrome"] {
        let runs = Command::new(name)
            .arg("--version")
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
        if runs {
            return Some(name);
        }
    }
    let has_apt = Command::new("apt-get")
        .arg("--version")
        .stdout(Stdio::null())
        .status()
        .is_ok();
    assert!(
        !in_ci() && !has_apt,
        "Chromium is not installed: `cargo xtask test` installs it (Debian: apt-get install chromium)"
    );
    eprintln!("skipping: no Chromium, and no apt-get to install it with (install Chromium with this system's package manager)");
    None
}

/// A directory of the test's own, empty.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("ommcheck-html-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("creating the test directory");
    dir
}

fn ommcheck(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_ommcheck"))
        .current_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join(".."))
        .args(args)
        .output()
        .expect("ommcheck runs")
}

/// Runs headless Chromium on `url` with `args`, its profile in `dir`,
/// logging the console to stderr, and prints how long it took (`label`
/// says which run); fails the test when it fails or runs past
/// [`CHROMIUM_TIMEOUT`].
fn run_chromium(chromium: &str, label: &str, dir: &Path, args: &[&str], url: &str) -> Output {
    let mut child = Command::new(chromium)
        .args([
            "--headless",
            // Tests run as root in containers, where the sandbox cannot start.
            "--no-sandbox",
            "--disable-gpu",
            "--disable-dev-shm-usage",
            "--no-first-run",
            "--disable-extensions",
            "--hide-scrollbars",
            // Console messages go to stderr as `...:CONSOLE...] "text"`.
            "--enable-logging=stderr",
            "--v=0",
        ])
        .arg(format!("--user-data-dir={}", dir.join("profile").display()))
        .args(args)
        .arg(url)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("Chromium starts");
    // Drained on threads: a full pipe would stall Chromium.
    let mut stdout = child.stdout.take().expect("piped");
    let mut stderr = child.stderr.take().expect("piped");
    let out = std::thread::spawn(move || {
        let mut bytes = Vec::new();
        std::io::Read::read_to_end(&mut stdout, &mut bytes).map(|_| bytes)
    });
    let err = std::thread::spawn(move || {
        let mut bytes = Vec::new();
        std::io::Read::read_to_end(&mut stderr, &mut bytes).map(|_| bytes)
    });
    let started = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().expect("waiting for Chromium") {
            break status;
        }
        if started.elapsed() > CHROMIUM_TIMEOUT {
            let _ = child.kill();
            let _ = child.wait();
            panic!("Chromium took more than {CHROMIUM_TIMEOUT:?} on {url}");
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let output = Output {
        status,
        stdout: out.join().expect("stdout thread").expect("stdout"),
        stderr: err.join().expect("stderr thread").expect("stderr"),
    };
    eprintln!("{label} took {:?}", started.elapsed());
    assert!(
        output.status.success(),
        "Chromium failed ({label}): {}",
        String::from_utf8_lossy(&output.stderr)
    );
    output
}

/// The console messages in Chromium's log.
fn console_messages(stderr: &[u8]) -> Vec<String> {
    String::from_utf8_lossy(stderr)
        .lines()
        .filter(|line| line.contains(":CONSOLE"))
        .map(str::to_string)
        .collect()
}

/// A page that opens `report` in a frame and, once it has loaded, writes
/// each of its images' state into `#result`, for `--dump-dom` to print:
/// the report itself has no script, and its policy would run none.
const HARNESS: &str = r#"<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>harness</title></head><body>
<pre id="result">not loaded</pre>
<iframe id="report" src="report.html" width="1200" height="900"></iframe>
<script>
document.getElementById("report").addEventListener("load", function () {
  var lines = [];
  var page = this.contentDocument;
  if (!page) {
    lines.push("no access to the report");
  } else {
    lines.push("title " + page.title);
    lines.push("images " + page.images.length);
    for (var i = 0; i < page.images.length; i++) {
      var image = page.images[i];
      var decoded = image.complete && image.naturalWidth > 0 && image.naturalHeight > 0;
      lines.push("image " + i + " " + (decoded ? "decoded" : "broken") + " " + image.naturalWidth + "x" + image.naturalHeight);
    }
  }
  document.getElementById("result").textContent = lines.join("\n");
});
</script>
</body></html>
"#;

/// What Chromium made of a page.
struct Inspection {
    /// The frame's title and each image's state, as the harness wrote them.
    result: String,
    /// Console messages while the harness and the page alone were open.
    console: Vec<String>,
    screenshot: resvg::tiny_skia::Pixmap,
}

impl Inspection {
    /// How many images the page has, by the harness.
    fn images(&self) -> Option<usize> {
        self.result
            .lines()
            .find_map(|line| line.strip_prefix("images "))
            .and_then(|n| n.parse().ok())
    }

    /// How many of them decoded.
    fn decoded(&self) -> usize {
        self.result
            .lines()
            .filter(|line| line.starts_with("image ") && line.contains(" decoded "))
            .count()
    }

    /// The screenshot's pixels within 8 of `colour` in each channel.
    fn pixels_near(&self, (r, g, b): (u8, u8, u8)) -> usize {
        self.screenshot
            .pixels()
            .iter()
            .filter(|p| {
                p.red().abs_diff(r) <= 8 && p.green().abs_diff(g) <= 8 && p.blue().abs_diff(b) <= 8
            })
            .count()
    }
}

/// Opens the page `html` in Chromium twice: in a frame of the harness,
/// which reports its images' state, and on its own for a screenshot, as
/// a reader opens it.
fn inspect(chromium: &str, name: &str, html: &[u8]) -> Inspection {
    let dir = scratch(name);
    std::fs::write(dir.join("report.html"), html).unwrap();
    std::fs::write(dir.join("harness.html"), HARNESS).unwrap();
    let url = |file: &str| format!("file://{}", dir.join(file).display());

    // file: pages reach each other's documents only with this flag.
    let dumped = run_chromium(
        chromium,
        &format!("{name}: --dump-dom"),
        &dir,
        &["--allow-file-access-from-files", "--dump-dom"],
        &url("harness.html"),
    );
    let dom = String::from_utf8_lossy(&dumped.stdout);
    let result = dom
        .split_once("<pre id=\"result\">")
        .and_then(|(_, rest)| rest.split_once("</pre>"))
        .map(|(result, _)| result.to_string())
        .unwrap_or_else(|| panic!("no result in the dumped DOM: {dom}"));

    let screenshot = dir.join("screenshot.png");
    let shot = run_chromium(
        chromium,
        &format!("{name}: --screenshot"),
        &dir,
        &[
            "--window-size=1200,2400",
            &format!("--screenshot={}", screenshot.display()),
        ],
        &url("report.html"),
    );
    let png = std::fs::read(&screenshot).expect("Chromium wrote the screenshot");
    let screenshot = resvg::tiny_skia::Pixmap::decode_png(&png).expect("the screenshot is a PNG");
    let mut console = console_messages(&dumped.stderr);
    console.extend(console_messages(&shot.stderr));
    let _ = std::fs::remove_dir_all(&dir);
    Inspection {
        result,
        console,
        screenshot,
    }
}

/// Checks a report's page: it loaded in the frame, its `images` images
/// all decoded, the console stayed silent, and the screenshot shows the
/// error badges and, where `pictures` says, the pictures' opaque blue.
fn assert_loads(inspection: &Inspection, images: usize, pictures: bool) {
    let result = &inspection.result;
    assert!(result.contains("title ommcheck report: "), "{result}");
    assert_eq!(inspection.images(), Some(images), "{result}");
    assert_eq!(
        inspection.decoded(),
        images,
        "images that did not decode: {result}"
    );
    assert_eq!(inspection.console, Vec::<String>::new(), "console messages");
    let shot = &inspection.screenshot;
    assert_eq!((shot.width(), shot.height()), (1200, 2400));
    // A badge is solid: a few hundred pixels each.
    assert!(
        inspection.pixels_near(ERROR_RED) > 200,
        "no error badge on the screenshot"
    );
    if pictures {
        // A picture's opaque cells are thousands of pixels.
        assert!(
            inspection.pixels_near(OPAQUE_BLUE) > 2000,
            "no picture on the screenshot"
        );
    }
}

/// The README's first command, as a page: the built-in example's three
/// mistakes, each with its picture.
#[test]
fn the_examples_page_loads_with_its_pictures_and_a_silent_console() {
    let Some(chromium) = chromium() else { return };
    let out = ommcheck(&["check", "--example", "--format", "html"]);
    assert_eq!(out.status.code(), Some(1), "errors found: status 1");
    let html = out.stdout;
    let text = String::from_utf8_lossy(&html);
    assert!(text.starts_with("<!DOCTYPE html>"));
    let images = text.matches("<img ").count();
    assert_eq!(images, 3, "a triangle, the micromap and the geometry");
    assert_loads(&inspect(chromium, "example", &html), images, true);
}

/// The mistakes scene and the whole corpus (893 scenes, hundreds of
/// findings) on one page beside the text report: the page's pictures stop
/// at its bound and it still loads.
#[test]
fn the_corpus_page_loads_within_its_bounds_and_a_silent_console() {
    let Some(chromium) = chromium() else { return };
    let dir = scratch("corpus-out");
    let file = dir.join("corpus.html");
    let out = ommcheck(&[
        "check",
        "tests/scenes/ext-quad-mistakes.json",
        "tests/scenes/corpus",
        "--html",
        file.to_str().expect("a UTF-8 temporary directory"),
    ]);
    assert_eq!(out.status.code(), Some(1), "errors found: status 1");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.starts_with("== tests/scenes/ext-quad-mistakes.json"),
        "the text report on stdout: {stdout:.200}"
    );
    let html = std::fs::read(&file).expect("the page was written");
    let text = String::from_utf8_lossy(&html);
    let images = text.matches("<img ").count();
    let most = ommcheck::html::LIMITS.pictures.pictures;
    assert_eq!(images, most);
    assert!(text.contains(&format!(
        "Picture left out: the page holds at most {most} pictures."
    )));
    assert!(text.contains("<h2>What was not checked, and why</h2>"));
    assert_loads(&inspect(chromium, "corpus", &html), images, false);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The checks above can fail: a picture that does not decode is reported
/// broken, and a stylesheet from elsewhere, which the page's policy
/// blocks, is reported on the console.
#[test]
fn a_broken_picture_and_an_outside_stylesheet_are_caught() {
    let Some(chromium) = chromium() else { return };
    let out = ommcheck(&["check", "--example", "--format", "html"]);
    let page = String::from_utf8(out.stdout).expect("UTF-8");
    let spoiled = page
        .replacen(
            "data:image/svg+xml;base64,",
            "data:image/svg+xml;base64,AAAA",
            1,
        )
        .replacen(
            "</head>",
            "<link rel=\"stylesheet\" href=\"https://example.com/style.css\">\n</head>",
            1,
        );
    let inspection = inspect(chromium, "spoiled", spoiled.as_bytes());
    assert_eq!(inspection.images(), Some(3), "{}", inspection.result);
    assert_eq!(inspection.decoded(), 2, "{}", inspection.result);
    assert!(
        inspection
            .console
            .iter()
            .any(|m| m.contains("https://example.com/style.css")
                && m.contains("Content Security Policy")),
        "{:?}",
        inspection.console
    );
}
