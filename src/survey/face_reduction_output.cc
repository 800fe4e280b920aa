// The face reduction for the terminal, adjusted.json and face_differences.csv.
#include <cstdio>
#include <sstream>

#include "mmba/survey/face_reduction.h"

namespace mmba::survey {
namespace {

std::string Format(const char* format, double v) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), format, v);
  return buffer;
}

std::string CsvField(const std::string& text) {
  if (text.find_first_of(",\"\n") == std::string::npos) return text;
  std::string out = "\"";
  for (char c : text) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

}  // namespace

std::string FaceReductionSummary(const FaceReduction& reduction) {
  std::ostringstream out;
  size_t pairs = 0;
  for (const SetupFaceSummary& s : reduction.setups) pairs += s.pairs;
  out << "  field book: " << reduction.setups.size() << " set-up(s), " << reduction.raw_observations
      << " pointings -> " << reduction.sets.size() << " set(s) (one per set-up and round), "
      << pairs << " face pair(s)\n";
  out << "  face differences: collimation c sigma " << Format("%.2f", reduction.collimation_std_mgon)
      << " mgon, index error i sigma " << Format("%.2f", reduction.index_std_mgon)
      << " mgon (about each set-up's median)\n";
  for (const SetupFaceSummary& s : reduction.setups) {
    out << "    " << s.station << " (line " << s.line << "): " << s.rounds << " round(s), "
        << s.pairs << " pair(s)";
    if (s.single_face) out << ", " << s.single_face << " single face";
    if (s.collimation_count) {
      out << ", c " << Format("%+.2f", s.collimation_mean_mgon) << " +- "
          << Format("%.2f", s.collimation_std_mgon) << " mgon";
    }
    if (s.index_count) {
      out << ", i " << Format("%+.2f", s.index_mean_mgon) << " +- "
          << Format("%.2f", s.index_std_mgon) << " mgon";
    }
    if (s.blunders) out << ", " << s.blunders << " beyond tolerance";
    out << "\n";
  }
  for (const std::string& b : reduction.blunders) out << "  face blunder: " << b << "\n";
  return out.str();
}

nlohmann::json FaceReductionToJson(const FaceReduction& reduction) {
  nlohmann::json j;
  j["raw_observations"] = reduction.raw_observations;
  j["sets"] = reduction.sets.size();
  j["pairs"] = reduction.pairs.size();
  j["collimation_std_mgon"] = reduction.collimation_std_mgon;
  j["index_std_mgon"] = reduction.index_std_mgon;
  j["setups"] = nlohmann::json::array();
  for (const SetupFaceSummary& s : reduction.setups) {
    j["setups"].push_back({{"station", s.station},
                           {"line", s.line},
                           {"rounds", s.rounds},
                           {"pairs", s.pairs},
                           {"single_face", s.single_face},
                           {"collimation_mean_mgon", s.collimation_mean_mgon},
                           {"collimation_median_mgon", s.collimation_median_mgon},
                           {"collimation_std_mgon", s.collimation_std_mgon},
                           {"index_mean_mgon", s.index_mean_mgon},
                           {"index_median_mgon", s.index_median_mgon},
                           {"index_std_mgon", s.index_std_mgon},
                           {"blunders", s.blunders}});
  }
  j["blunders"] = reduction.blunders;
  return j;
}

std::string FaceDifferencesCsv(const FaceReduction& reduction) {
  std::ostringstream out;
  out << "setup,station,round,target,line_face1,line_face2,collimation_mgon,index_mgon,"
         "distance_difference_mm,blunder\n";
  for (const FacePair& p : reduction.pairs) {
    out << p.setup + 1 << "," << CsvField(p.station) << "," << p.round << "," << CsvField(p.target)
        << "," << p.line_face1 << "," << p.line_face2 << ","
        << (p.has_collimation ? Format("%.3f", p.collimation_mgon) : "") << ","
        << (p.has_index ? Format("%.3f", p.index_mgon) : "") << ","
        << (p.has_distance_difference ? Format("%.1f", p.distance_difference_mm) : "") << ","
        << CsvField(p.blunder) << "\n";
  }
  return out.str();
}

}  // namespace mmba::survey
