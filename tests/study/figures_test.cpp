// alc study report --svg: the SVG figures of a study (study/figures.hpp), drawn from a synthetic study
// (no controller runs), parsed as XML and checked against the analysis.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "../cli_support.hpp"
#include "storage/study_store.hpp"
#include "study/analysis.hpp"
#include "study/figures.hpp"
#include "study/results.hpp"

namespace fs = std::filesystem;
using alc::storage::StudyRowRecord;
using alc::study::StudyInfo;

namespace {

// ---- A small XML parser: well-formedness (tags nest, attributes quoted and unique, entities known,
// no stray '<' or '&', one root element) and a tree to query. --------------------------------------

struct Element {
  std::string name;
  std::map<std::string, std::string> attrs;
  std::vector<Element> children;
  std::string text;  // the element's own character data, entities decoded

  bool has_class(const std::string& token) const {
    const auto it = attrs.find("class");
    if (it == attrs.end()) return false;
    std::size_t at = 0;
    const std::string& s = it->second;
    while (at <= s.size()) {
      const std::size_t end = std::min(s.find(' ', at), s.size());
      if (s.substr(at, end - at) == token) return true;
      at = end + 1;
    }
    return false;
  }
  std::string attr(const std::string& k) const {
    const auto it = attrs.find(k);
    return it == attrs.end() ? std::string() : it->second;
  }
};

class XmlParser {
 public:
  explicit XmlParser(std::string text) : s_(std::move(text)) {}

  Element parse() {
    if (s_.compare(0, 5, "<?xml") == 0) {
      const auto end = s_.find("?>");
      if (end == std::string::npos) fail("unterminated XML declaration");
      i_ = end + 2;
    }
    misc();
    if (i_ >= s_.size() || s_[i_] != '<') fail("no root element");
    Element root = element();
    misc();
    if (i_ != s_.size()) fail("content after the root element");
    return root;
  }

 private:
  [[noreturn]] void fail(const std::string& why) const {
    throw std::runtime_error("XML not well-formed at byte " + std::to_string(i_) + ": " + why);
  }
  bool starts(const char* p) const { return s_.compare(i_, std::char_traits<char>::length(p), p) == 0; }
  void space() {
    while (i_ < s_.size() && (s_[i_] == ' ' || s_[i_] == '\n' || s_[i_] == '\t' || s_[i_] == '\r')) ++i_;
  }
  void comment() {
    const auto end = s_.find("-->", i_ + 4);
    if (end == std::string::npos) fail("unterminated comment");
    i_ = end + 3;
  }
  void misc() {
    for (;;) {
      space();
      if (starts("<!--")) comment();
      else return;
    }
  }
  static bool name_char(char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == ':' || c == '.';
  }
  std::string name() {
    const std::size_t b = i_;
    if (i_ >= s_.size() || !(std::isalpha(static_cast<unsigned char>(s_[i_])) || s_[i_] == '_')) fail("bad name");
    while (i_ < s_.size() && name_char(s_[i_])) ++i_;
    return s_.substr(b, i_ - b);
  }
  // Character data up to `stop` (not included), entities decoded; '<' is not allowed in it.
  std::string chars(char stop) {
    std::string out;
    while (i_ < s_.size() && s_[i_] != stop) {
      const char c = s_[i_];
      if (c == '<') fail("'<' in character data");
      if (c == '&') {
        const auto semi = s_.find(';', i_);
        if (semi == std::string::npos || semi - i_ > 10) fail("unterminated entity");
        const std::string e = s_.substr(i_ + 1, semi - i_ - 1);
        if (e == "amp") out += '&';
        else if (e == "lt") out += '<';
        else if (e == "gt") out += '>';
        else if (e == "quot") out += '"';
        else if (e == "apos") out += '\'';
        else if (e.size() > 1 && e[0] == '#') out += '?';  // a character reference (not needed decoded here)
        else fail("unknown entity &" + e + ";");
        i_ = semi + 1;
        continue;
      }
      out += c;
      ++i_;
    }
    return out;
  }
  Element element() {
    ++i_;  // '<'
    Element e;
    e.name = name();
    for (;;) {
      const std::size_t before = i_;
      space();
      if (starts("/>")) {
        i_ += 2;
        return e;
      }
      if (starts(">")) {
        ++i_;
        break;
      }
      if (i_ == before) fail("no space before an attribute");
      const std::string k = name();
      space();
      if (!starts("=")) fail("attribute " + k + " without '='");
      ++i_;
      space();
      if (i_ >= s_.size() || (s_[i_] != '"' && s_[i_] != '\'')) fail("attribute " + k + " not quoted");
      const char q = s_[i_++];
      std::string v = chars(q);
      if (i_ >= s_.size()) fail("unterminated attribute value");
      ++i_;
      if (!e.attrs.emplace(k, std::move(v)).second) fail("attribute " + k + " twice");
    }
    for (;;) {
      if (i_ >= s_.size()) fail("element <" + e.name + "> not closed");
      if (starts("</")) {
        i_ += 2;
        if (name() != e.name) fail("closing tag does not match <" + e.name + ">");
        space();
        if (!starts(">")) fail("bad closing tag");
        ++i_;
        return e;
      }
      if (starts("<!--")) comment();
      else if (starts("<![CDATA[") || starts("<!") || starts("<?")) fail("unexpected markup");
      else if (s_[i_] == '<') e.children.push_back(element());
      else e.text += chars('<');
    }
  }

  std::string s_;
  std::size_t i_ = 0;
};

Element parse_file(const fs::path& file) { return XmlParser(alc_test::slurp(file)).parse(); }

void collect(const Element& e, const std::string& cls, std::vector<const Element*>& out) {
  if (e.has_class(cls)) out.push_back(&e);
  for (const Element& ch : e.children) collect(ch, cls, out);
}
std::vector<const Element*> by_class(const Element& root, const std::string& cls) {
  std::vector<const Element*> out;
  collect(root, cls, out);
  return out;
}
const Element* child(const Element& e, const std::string& name) {
  for (const Element& ch : e.children)
    if (ch.name == name) return &ch;
  return nullptr;
}

std::string fmt2(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.2f", v);
  return b;
}

// ---- The synthetic study ---------------------------------------------------------------------------

constexpr const char* kGrid = R"toml(cp = [6.5, 12]
interval = [2, 6, "inf"]
ng-interval = [10]
ng-meas = [6, 12]
)toml";

StudyInfo make_info(const char* grid = kGrid) {
  StudyInfo info;
  info.grid = alc::study::parse_grid(grid, "grid.toml");
  info.sets = info.grid.sets();
  // The second case's name needs escaping in the SVG and in a file name.
  info.cases = {{"A", "case A", "0000000000000001"}, {"data/b&c<1>.csv", "file data/b&c<1>.csv", "0000000000000002"}};
  info.software_version = "alc test";
  return info;
}

// One row per set and case: P99 and Pd made up from the indices; one failed row and one with an
// infinite P99 on case A.
std::vector<StudyRowRecord> make_rows(const StudyInfo& info, std::size_t* failed_set = nullptr,
                                      std::size_t* infinite_set = nullptr) {
  std::vector<StudyRowRecord> rows;
  const std::size_t n = info.sets.size();
  const std::size_t bad = n - 1, inf = n - 2;  // cp 12 sets, neither the paper set nor an optimum
  if (failed_set) *failed_set = bad;
  if (infinite_set) *infinite_set = inf;
  for (std::size_t s = 0; s < n; ++s)
    for (std::size_t c = 0; c < info.cases.size(); ++c) {
      StudyRowRecord r;
      r.set_index = static_cast<std::int64_t>(s);
      r.case_index = static_cast<std::int64_t>(c);
      if (c == 0 && s == bad) {
        r.ok = false;
        r.error = "made-up failure";
      } else {
        r.p99_linear = 2.0 + static_cast<double>((s * 7 + c * 3) % 10) * 0.9;
        r.p99_angular = 4.0;
        r.pd = 90.0 + static_cast<double>((s * 5 + c * 11) % 13) * 0.55;
        if (c == 0 && s == inf) {
          r.p99_linear = INFINITY;
          r.pd = 85.0;
        }
        r.report_json = R"({"outputs": {}, "M": 42})";
      }
      rows.push_back(r);
    }
  return rows;
}

std::size_t set_of(const StudyInfo& info, const std::string& key) {
  for (const auto& s : info.sets)
    if (s.key == key) return s.index;
  FAIL("no set " << key);
  return 0;
}

}  // namespace

TEST_CASE("figures: cases whose file parts collide get one figure each", "[study][figures]") {
  // 'x y' writes x_y; case 3's first fallback, x_y-3, was case 1's own name: one figure was lost, and
  // alc report had the id study-pareto-x_y-3 twice.
  StudyInfo info = make_info();
  info.cases = {{"x_y-3", "file x_y-3", "0000000000000001"},
                {"x y", "file x y", "0000000000000002"},
                {"x_y", "file x_y", "0000000000000003"}};
  const alc::study::Analysis a = alc::study::analyse(info, make_rows(info));
  REQUIRE(a.cases.size() == 3);
  const auto rendered = alc::study::render_figures(info, make_rows(info), a, std::string("6.5"));
  std::vector<std::string> names;
  for (std::size_t c = 0; c < 3; ++c) names.push_back(rendered.figures.at(c).name);
  CHECK(names == std::vector<std::string>{"pareto-x_y-3", "pareto-x_y", "pareto-x_y-4"});
}

TEST_CASE("figures: pareto plots and heat maps are well-formed SVG matching the analysis", "[study][figures]") {
  const StudyInfo info = make_info();
  REQUIRE(info.sets.size() == 10);  // per CP: interval 2 and 6 with two ng-meas each, inf once
  std::size_t failed_set = 0, infinite_set = 0;
  const auto rows = make_rows(info, &failed_set, &infinite_set);
  const alc::study::Analysis a = alc::study::analyse(info, rows);
  REQUIRE(a.paper_set);
  REQUIRE(a.cases.size() == 2);
  REQUIRE(a.cases[0].optimum);

  const fs::path dir = alc_test::work_dir("study_figures") / "svg" / "nested";
  fs::remove_all(dir);
  const auto written = alc::study::write_figures(info, rows, a, dir, std::string("6.5"));
  REQUIRE(written.notes.empty());
  REQUIRE(written.files.size() == 4);
  CHECK(written.files[0] == dir / "pareto-A.svg");
  CHECK(written.files[1] == dir / "pareto-data_b_c_1_.csv.svg");
  CHECK(written.files[2] == dir / "heatmap-p99-cp6.5.svg");
  CHECK(written.files[3] == dir / "heatmap-pd-cp6.5.svg");
  for (const auto& f : written.files) REQUIRE(fs::is_regular_file(f));

  for (std::size_t c = 0; c < 2; ++c) {
    INFO("case " << info.cases[c].name);
    const Element svg = parse_file(written.files[c]);
    CHECK(svg.name == "svg");
    CHECK(svg.attr("xmlns") == "http://www.w3.org/2000/svg");
    std::size_t finite = 0;
    for (const auto& r : rows)
      if (r.case_index == static_cast<std::int64_t>(c) && r.ok && r.p99_linear && r.pd && std::isfinite(*r.p99_linear) &&
          std::isfinite(*r.pd))
        ++finite;
    CHECK(finite == (c == 0 ? info.sets.size() - 2 : info.sets.size()));
    CHECK(by_class(svg, "row").size() == finite);
    const auto poly = by_class(svg, "pareto");
    REQUIRE(poly.size() == 1);
    CHECK(poly[0]->name == "polyline");
    std::size_t pairs = 0;
    for (const char ch : poly[0]->attr("points")) pairs += ch == ',';
    CHECK(pairs == a.cases[c].pareto.size());
    CHECK(by_class(svg, "pareto-point").size() == a.cases[c].pareto.size());
    CHECK(by_class(svg, "optimum").size() == (a.cases[c].optimum ? 1u : 0u));
    CHECK(by_class(svg, "paper").size() == 1);
    CHECK(by_class(svg, "limit").size() == 1);
    CHECK(by_class(svg, "limit")[0]->attr("stroke-dasharray") != "");
    // Title names the case (escaped in the file, decoded by the parser); units on both axes.
    const auto title = by_class(svg, "title");
    REQUIRE(title.size() == 1);
    CHECK(title[0]->text.find("Case " + info.cases[c].name + ":") == 0);
    CHECK(by_class(svg, "xlabel")[0]->text.find("[%]") != std::string::npos);
    CHECK(by_class(svg, "ylabel")[0]->text.find("[µm]") != std::string::npos);
    const auto notes = by_class(svg, "note");
    if (c == 0) {
      REQUIRE(notes.size() == 1);
      CHECK(notes[0]->text.find("2 rows") != std::string::npos);
    } else {
      CHECK(notes.empty());
    }
  }

  // Heat maps at CP 6.5 h: interval 2 and 6 by ng-meas 6 and 12, and interval = inf as one cell.
  for (const bool p99 : {true, false}) {
    INFO((p99 ? "P99" : "Pd"));
    const Element svg = parse_file(written.files[p99 ? 2 : 3]);
    const auto cells = by_class(svg, "cell");
    CHECK(cells.size() == 5);
    std::set<std::pair<std::string, std::string>> seen;
    for (const Element* cell : cells) {
      const std::string iv = cell->attr("data-interval"), nm = cell->attr("data-ng-meas");
      seen.emplace(iv, nm);
      const std::string key = iv == "inf" ? "cp=6.5 interval=inf" : "cp=6.5 interval=" + iv + " ng-interval=10 ng-meas=" + nm;
      const std::size_t set = set_of(info, key);
      CHECK(cell->attr("data-set") == std::to_string(set));
      double sum = 0;
      for (const auto& r : rows)
        if (r.set_index == static_cast<std::int64_t>(set)) sum += p99 ? *r.p99_linear : *r.pd;
      const double mean = sum / 2.0;
      const Element* text = child(*cell, "text");
      REQUIRE(text);
      CHECK(text->text == fmt2(mean));
      CHECK(std::stod(cell->attr("data-value")) == Approx(mean).epsilon(1e-12));
    }
    const std::set<std::pair<std::string, std::string>> want{{"2", "6"}, {"2", "12"}, {"6", "6"}, {"6", "12"}, {"inf", "all"}};
    CHECK(seen == want);
    CHECK(by_class(svg, "empty").empty());
    const auto fixed = by_class(svg, "fixed");
    REQUIRE(fixed.size() == 1);
    CHECK(fixed[0]->text.find("cp = 6.5 h") != std::string::npos);
    CHECK(fixed[0]->text.find("ng-interval = 10 min") != std::string::npos);
    CHECK(by_class(svg, "xlabel")[0]->text.find("[h]") != std::string::npos);
    CHECK(by_class(svg, "ylabel")[0]->text.find("[-]") != std::string::npos);
  }
}

TEST_CASE("figures: heat map CP by value and its default", "[study][figures]") {
  const StudyInfo info = make_info();
  const auto rows = make_rows(info);
  const alc::study::Analysis a = alc::study::analyse(info, rows);
  CHECK(alc::study::cp_values(info) == std::vector<std::string>{"6.5", "12"});
  CHECK(alc::study::grid_cp(info, "12.0") == "12");
  CHECK(alc::study::grid_cp(info, "6.50") == "6.5");
  for (const std::string bad : {"7", "abc", "", "-6.5"}) {
    INFO(bad);
    try {
      alc::study::grid_cp(info, bad);
      FAIL("no FigureError");
    } catch (const alc::study::FigureError& e) {
      const std::string m = e.what();
      CHECK(m.find("'" + bad + "'") != std::string::npos);
      CHECK(m.find("6.5, 12") != std::string::npos);
    }
  }
  REQUIRE(a.cases[0].optimum);
  const std::string want = info.sets[a.cases[0].optimum->set].value("cp");
  CHECK(alc::study::default_heatmap_cp(info, a) == want);
  const fs::path dir = alc_test::work_dir("study_figures") / "default_cp";
  const auto w = alc::study::write_figures(info, rows, a, dir, std::nullopt);
  REQUIRE(w.files.size() == 4);
  CHECK(w.files[2].filename() == "heatmap-p99-cp" + want + ".svg");
  // At CP 12 h two rows of case A have no finite value: their sets' means are over one case (marked *).
  const auto w12 = alc::study::write_figures(info, rows, a, dir, std::string("12"));
  const Element svg = parse_file(w12.files[2]);
  std::size_t starred = 0;
  for (const Element* cell : by_class(svg, "cell")) {
    const Element* text = child(*cell, "text");
    REQUIRE(text);
    if (!text->text.empty() && text->text.back() == '*') ++starred;
  }
  CHECK(starred == 2);
}

TEST_CASE("figures: a grid without an ng-meas axis gets no heat map and a note", "[study][figures]") {
  const StudyInfo info = make_info("cp = [6.5, 12]\ninterval = [2, \"inf\"]\n");
  const auto rows = make_rows(info);
  const alc::study::Analysis a = alc::study::analyse(info, rows);
  const auto w = alc::study::write_figures(info, rows, a, alc_test::work_dir("study_figures") / "no_heatmap", std::nullopt);
  CHECK(w.files.size() == 2);
  REQUIRE(w.notes.size() == 1);
  CHECK(w.notes[0].find("ng-meas") != std::string::npos);
  for (const auto& f : w.files) CHECK_NOTHROW(parse_file(f));
}

TEST_CASE("figures: XML escaping of text and bytes XML cannot hold", "[study][figures]") {
  CHECK(alc::study::xml_escape("a<b>&\"c'") == "a&lt;b&gt;&amp;&quot;c&apos;");
  CHECK(alc::study::xml_escape("µm") == "µm");
  CHECK(alc::study::xml_escape(std::string("x\x01y")) == "x\xEF\xBF\xBDy");
  CHECK(alc::study::xml_escape(std::string("\xFF\xC3")) == "\xEF\xBF\xBD\xEF\xBF\xBD");
  CHECK(alc::study::xml_escape("tab\tnew\nline") == "tab\tnew\nline");
  // The parser of these tests refuses what is not well-formed.
  CHECK_THROWS(XmlParser("<a><b></a></b>").parse());
  CHECK_THROWS(XmlParser("<a x=\"1\" x=\"2\"/>").parse());
  CHECK_THROWS(XmlParser("<a>&nbsp;</a>").parse());
  CHECK_THROWS(XmlParser("<a>1 < 2</a>").parse());
  CHECK_THROWS(XmlParser("<a/><b/>").parse());
  CHECK_NOTHROW(XmlParser("<?xml version=\"1.0\"?>\n<a k='v &amp; w'><!-- c --><b/>t&lt;</a>\n").parse());
}

TEST_CASE("figures: alc study report --svg and a --heatmap-cp not in the grid", "[study][figures][cli]") {
  const StudyInfo info = make_info();
  const auto rows = make_rows(info);
  const fs::path dir = alc_test::work_dir("study_figures_cli");
  const fs::path db = dir / "study.sqlite";
  fs::remove(db);
  {
    alc::storage::StudyStore store(db, info.header(), alc::storage::StudyStore::Existing::Refuse);
    store.add(rows);
  }
  const fs::path out = dir / "svg";
  fs::remove_all(out);
  const auto bad = alc_test::run_alc("study report \"" + db.string() + "\" --svg \"" + out.string() + "\" --heatmap-cp 7",
                                     "study_figures_cli");
  CHECK(bad.exit_code == 2);
  CHECK(bad.err.find("'7'") != std::string::npos);
  CHECK(bad.err.find("6.5, 12") != std::string::npos);
  CHECK_FALSE(fs::exists(out));
  const auto ok = alc_test::run_alc("study report \"" + db.string() + "\" --svg \"" + out.string() + "\" --heatmap-cp 12",
                                    "study_figures_cli");
  INFO(ok.err);
  CHECK(ok.exit_code == 0);
  CHECK(ok.out.find("Eq. 8 optimum") != std::string::npos);
  CHECK(ok.err.find("4 figures") != std::string::npos);
  for (const char* f : {"pareto-A.svg", "pareto-data_b_c_1_.csv.svg", "heatmap-p99-cp12.svg", "heatmap-pd-cp12.svg"})
    CHECK(fs::is_regular_file(out / f));
}

TEST_CASE("figures: a pareto plot renders in headless chromium", "[study][figures][chromium]") {
  std::string browser;
  for (const char* b : {"chromium", "chromium-browser", "google-chrome"})
    if (std::system(("command -v " + std::string(b) + " >/dev/null 2>&1").c_str()) == 0) {
      browser = b;
      break;
    }
  if (browser.empty()) {
    WARN("chromium is not installed: the rendering check is skipped");
    return;
  }
  const StudyInfo info = make_info();
  const auto rows = make_rows(info);
  const alc::study::Analysis a = alc::study::analyse(info, rows);
  const fs::path dir = alc_test::work_dir("study_figures_chromium");
  const auto w = alc::study::write_figures(info, rows, a, dir / "svg", std::nullopt);
  for (const fs::path& svg : {w.files[0], w.files[2]}) {
    const fs::path png = dir / (svg.stem().string() + ".png");
    fs::remove(png);
    const std::string cmd = "timeout 120 " + browser + " --headless=new --no-sandbox --disable-gpu --hide-scrollbars" +
                            " --user-data-dir=\"" + (dir / "profile").string() + "\" --window-size=1000,640" +
                            " --screenshot=\"" + png.string() + "\" \"file://" + fs::absolute(svg).string() +
                            "\" >\"" + (dir / "chromium.log").string() + "\" 2>&1";
    const int status = std::system(cmd.c_str());
    INFO(cmd << "\n" << alc_test::slurp(dir / "chromium.log"));
    CHECK(status == 0);
    REQUIRE(fs::is_regular_file(png));
    const std::string bytes = alc_test::slurp(png);
    CHECK(bytes.compare(0, 8, "\x89PNG\r\n\x1a\n") == 0);
    CHECK(bytes.size() > 10000);  // a blank 1000 x 640 page compresses to a few hundred bytes
  }
}
