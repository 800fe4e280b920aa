#include "arguments.h"

#include <algorithm>
#include <cctype>
#include <limits>
#include <vector>

#include "mmba/core/settings_table.h"  // EditDistance

namespace mmba::app {
namespace {

// The candidate closest to `word`, if close enough to be a likely typo: at most a third of the
// word's letters (and at least 2) edited. Empty otherwise.
std::string Closest(const std::string& word, const std::vector<std::string>& candidates) {
  std::string best;
  size_t best_distance = std::numeric_limits<size_t>::max();
  for (const std::string& c : candidates) {
    const size_t d = EditDistance(word, c);
    if (d < best_distance) best_distance = d, best = c;
  }
  const size_t allowed = std::max<size_t>(2, word.size() / 3);
  return best_distance <= allowed ? best : std::string();
}

std::string Suggest(const std::string& closest) {
  return closest.empty() ? std::string() : "; did you mean '" + closest + "'?";
}

// "--name" of "--name=value"; "-x" stays; a negative number ("-0.1", "-5") is a value.
bool OptionWord(const std::string& arg, std::string* name) {
  if (arg.size() < 2 || arg[0] != '-' || arg == "--") return false;
  if (std::isdigit(static_cast<unsigned char>(arg[1])) || arg[1] == '.') return false;
  *name = arg.substr(0, arg.find('='));
  return true;
}

std::vector<std::string> OptionNames(const CLI::App& sub) {
  std::vector<std::string> names;
  for (const CLI::Option* option : sub.get_options()) {
    for (const std::string& l : option->get_lnames()) names.push_back("--" + l);
    for (const std::string& s : option->get_snames()) names.push_back("-" + s);
  }
  return names;
}

}  // namespace

std::string UnknownArgument(const CLI::App& app, int argc, char** argv) {
  if (argc < 2) return "";
  const std::string first = argv[1];
  std::string name;
  if (OptionWord(first, &name)) {
    if (name == "--help" || name == "-h" || name == "--version") return "";
    return "unknown option '" + name + "' before the command" +
           Suggest(Closest(name, {"--help", "--version"})) + " (mmba --help lists the commands)";
  }
  const CLI::App* sub = nullptr;
  std::vector<std::string> commands;
  for (const CLI::App* candidate : app.get_subcommands({})) {
    commands.push_back(candidate->get_name());
    if (candidate->get_name() == first) sub = candidate;
  }
  if (sub == nullptr) {
    return "unknown command '" + first + "'" + Suggest(Closest(first, commands)) +
           " (mmba --help lists the commands)";
  }
  const std::vector<std::string> names = OptionNames(*sub);
  for (int i = 2; i < argc; ++i) {
    if (!OptionWord(argv[i], &name)) continue;
    if (std::find(names.begin(), names.end(), name) != names.end()) continue;
    return "unknown option '" + name + "' of mmba " + first + Suggest(Closest(name, names)) + " (mmba " +
           first + " --help lists the options)";
  }
  return "";
}

}  // namespace mmba::app
