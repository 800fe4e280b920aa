// report.html: where the result stands and how it was made — the coordinate reference system,
// the settings in force, the files; paths shown relative to the project folder.
#include <cctype>
#include <filesystem>
#include <string>

#include "report/html_internal.h"

namespace mmba::report::internal {
namespace {

namespace fs = std::filesystem;

/// A scalar JSON value as text: strings as they are, numbers and booleans as JSON writes them.
std::string ScalarText(const json& v) {
  if (v.is_null()) return kDash;
  if (v.is_string()) return v.get<std::string>();
  return v.dump(-1, ' ', false, json::error_handler_t::replace);
}

/// Rows "key | value" of an object; nested objects as "key.sub", arrays of scalars joined.
void FlatRows(const json& object, const std::string& prefix, const PageContext& context, std::ostringstream& html) {
  for (auto it = object.begin(); it != object.end(); ++it) {
    const std::string key = prefix.empty() ? it.key() : prefix + "." + it.key();
    if (it->is_object()) {
      FlatRows(*it, key, context, html);
      continue;
    }
    std::string value;
    if (it->is_array()) {
      for (const json& e : *it) value += (value.empty() ? "" : ", ") + (e.is_object() || e.is_array() ? e.dump() : ScalarText(e));
    } else {
      value = ScalarText(*it);
    }
    html << "<tr><th>" << Esc(key) << "</th><td>";
    if (value.size() > 120) {  // a WKT or a long PROJ string: folded, wrapped
      html << "<details><summary>" << value.size() << " characters</summary><pre class=\"wrap\">"
           << Esc(context.Text(value)) << "</pre></details>";
    } else {
      html << "<code>" << Esc(context.Text(value)) << "</code>";
    }
    html << "</td></tr>\n";
  }
}

/// The short name of a CRS: the string, or an object's name with its code (EPSG:nnnn).
std::string CrsName(const json& crs) {
  if (crs.is_string()) return crs.get<std::string>();
  std::string name = OptString(crs, "name", "crs").value_or("");
  std::string code;
  for (const char* key : {"code", "identifier", "id", "epsg"}) {
    const json* v = Member(crs, key);
    if (v == nullptr) continue;
    code = v->is_number() ? "EPSG:" + ScalarText(*v) : ScalarText(*v);
    break;
  }
  if (name.empty()) return code;
  return code.empty() ? name : name + " (" + code + ")";
}

}  // namespace

std::string PageContext::Path(const std::string& path) const {
  const fs::path p(path), base(project_dir);
  // Without the project folder an absolute path is shown by its file name: no local folder
  // names in a page that is sent on.
  if (project_dir.empty()) return p.is_absolute() ? p.filename().string() : path;
  if (path.empty() || !p.is_absolute() || !base.is_absolute()) return path;
  const fs::path relative = p.lexically_normal().lexically_relative(base.lexically_normal());
  return relative.empty() ? path : relative.string();
}

std::string PageContext::Text(const std::string& text) const {
  std::string base = project_dir;
  while (base.size() > 1 && base.back() == '/') base.pop_back();
  if (base.size() < 2) return text;
  std::string out;
  size_t from = 0;
  for (size_t at; (at = text.find(base, from)) != std::string::npos;) {
    const size_t end = at + base.size();
    out += text.substr(from, at - from);
    from = end;
    if (end < text.size() && text[end] == '/') {
      ++from;  // "<project_dir>/x" -> "x"
    } else if (end == text.size() || !(std::isalnum(static_cast<unsigned char>(text[end])) || text[end] == '_' ||
                                        text[end] == '-' || text[end] == '.')) {
      out += ".";  // the folder itself
    } else {
      out += base;  // a longer name that starts like the folder
    }
  }
  return out + text.substr(from);
}

void RenderCrsRow(const json& report, std::ostringstream& html) {
  const json* crs = Member(report, "crs");
  if (crs == nullptr) return;
  if (!crs->is_string() && !crs->is_object()) Fail("crs", Describe(*crs), "a string or an object");
  html << "<tr><th>Coordinate reference system</th><td>" << Esc(CrsName(*crs)) << " <a href=\"#crs\">(details)</a></td></tr>\n";
}

void RenderCrs(const json& report, std::ostringstream& html) {
  const json* crs = Member(report, "crs");
  if (crs == nullptr) return;
  if (!crs->is_string() && !crs->is_object()) Fail("crs", Describe(*crs), "a string or an object");
  html << "<section id=\"crs\">\n<h2>Coordinate reference system</h2>\n<table class=\"meta\">\n";
  if (crs->is_string()) {
    html << "<tr><th>CRS</th><td><code>" << Esc(crs->get<std::string>()) << "</code></td></tr>\n";
  } else {
    FlatRows(*crs, "", PageContext{}, html);
  }
  html << "</table>\n<p class=\"note\">The adjustment works in the local east-north-up frame at the origin "
          "given above; coordinates in this CRS are converted with PROJ at input and output.</p>\n</section>\n";
}

void RenderSettings(const json& report, const PageContext& context, std::ostringstream& html) {
  const json* settings = OptObject(report, "settings", "");
  const json* mmba = OptObject(report, "mmba", "");
  if (settings == nullptr && mmba == nullptr) return;
  html << "<section id=\"settings\">\n<h2>Program and settings in force</h2>\n<table class=\"meta\">\n";
  if (mmba != nullptr) {
    html << "<tr><th>mmba</th><td>version " << Esc(ReqString(*mmba, "version", "mmba")) << ", commit <code>"
         << Esc(ReqString(*mmba, "commit", "mmba")) << "</code></td></tr>\n";
  }
  if (settings != nullptr) FlatRows(*settings, "", context, html);
  html << "</table>\n";
  if (settings == nullptr) html << "<p class=\"note\">report.json lists no settings (key <code>settings</code>).</p>\n";
  html << "</section>\n";
}

void RenderFiles(const json& report, const PageContext& context, std::ostringstream& html) {
  const json* array = OptArray(report, "files", "");
  if (array == nullptr || array->empty()) return;
  html << "<section id=\"files\">\n<h2>Files</h2>\n<table>\n<tr><th>file</th><th>content</th></tr>\n";
  for (size_t i = 0; i < array->size(); ++i) {
    const std::string path = Index("files", i);
    const json& f = ElementObject(*array, i, "files");
    html << "<tr><td><code>" << Esc(context.Path(ReqString(f, "name", path))) << "</code></td>"
         << TdText(Esc(context.Text(OptString(f, "description", path).value_or("")))) << "</tr>\n";
  }
  html << "</table>\n<p class=\"note\">Names relative to the output folder";
  if (!context.project_dir.empty()) html << "; other paths relative to the project folder";
  html << ".</p>\n</section>\n";
}

}  // namespace mmba::report::internal
