// The report of an evaluation over a simulated scene (mmba::registration::WriteSceneEvaluation):
// results.csv, one row per (cell, method), and tables.md — Table I (each modality to the LiDAR
// model), Table II (the cross-modal matrix per method) and the best method per cell, with the
// reference started at the truth when it ran.

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <sstream>

#include "mmba/core/atomic_file.h"
#include "mmba/registration/cloud/scene_evaluation.h"

namespace mmba::registration {
namespace {

namespace fs = std::filesystem;

std::string Seconds(double s) {
  std::ostringstream out;
  out << std::setprecision(2) << s << " s";
  return out.str();
}

// results.csv: every row's figures; the reason quoted (its '"' as '\'').
void WriteResultsCsv(const SceneEvaluation& eval, std::ostream& out) {
  out << "experiment,source,target,method,status,rms_m,success,accurate,runtime_s,fitness,"
         "confidence,resolution_m,sigma_rms_m,visibility,violation,intensity_correlation,reason\n";
  out << std::setprecision(6);
  for (const EvalRow& r : eval.rows) {
    std::string reason = r.reason;
    std::replace(reason.begin(), reason.end(), '"', '\'');
    out << r.experiment << ',' << r.source << ',' << r.target << ',' << r.method << ','
        << r.status << ',' << r.rms_m << ',' << (r.success ? 1 : 0) << ','
        << (r.accurate ? 1 : 0) << ',' << r.runtime_s << ',' << r.fitness << ','
        << r.confidence << ',' << r.resolution_m << ',' << r.sigma_rms_m << ','
        << (r.visibility ? 1 : 0) << ','
        << r.violation << ',';
    // empty when the intensity test did not run
    if (r.intensity_correlation >= 0) out << r.intensity_correlation;
    out << ",\"" << reason << "\"\n";
  }
}

// The methods in the order of their first row.
std::vector<std::string> MethodsOf(const SceneEvaluation& eval) {
  std::vector<std::string> methods;
  for (const EvalRow& r : eval.rows) {
    if (std::find(methods.begin(), methods.end(), r.method) == methods.end()) {
      methods.push_back(r.method);
    }
  }
  return methods;
}

// A table cell: RMS m, ✓ success / ✗ failure, the status unless ok, the resolution an ok
// states, runtime s; "no pose" for a row without RMS.
std::string CellText(const EvalRow& r) {
  std::ostringstream s;
  if (std::isnan(r.rms_m)) return "no pose (" + r.status + "), " + Seconds(r.runtime_s);
  s << std::setprecision(3) << r.rms_m << (r.success ? " ✓" : " ✗")
    << (r.status == "ok" ? "" : " (" + r.status + ")");
  if (r.status == "ok") s << " (ok, resolved to " << r.resolution_m << " m)";
  s << ", " << Seconds(r.runtime_s);
  return s.str();
}

// Table I: each modality registered to the LiDAR model, one column per method.
void WriteTableI(const SceneEvaluation& eval, const std::vector<std::string>& methods, std::ostream& out) {
  // Table I.
  out << "Table I — each modality registered to the LiDAR model\n\n| modality |";
  for (const auto& m : methods) out << ' ' << m << " |";
  out << "\n|---|";
  for (size_t i = 0; i < methods.size(); ++i) out << "---|";
  out << '\n';
  for (const std::string& mod : eval.modalities) {
    out << "| " << mod << " |";
    for (const auto& method : methods) {
      std::string c = "–";
      for (const EvalRow& r : eval.rows) {
        if (r.experiment == "to-lidar" && r.source == mod && r.method == method) c = CellText(r);
      }
      out << ' ' << c << " |";
    }
    out << '\n';
  }
}

// Table II: per method, each part (rows) registered to each other full model (columns), with
// its counts of successes, accurate poses and poses refused within the threshold.
void WriteTableII(const SceneEvaluation& eval, const std::vector<std::string>& methods, std::ostream& out) {
  // Table II.
  std::vector<std::string> parts, targets;
  for (const EvalRow& r : eval.rows) {
    if (r.experiment != "cross-modal") continue;
    if (std::find(parts.begin(), parts.end(), r.source) == parts.end()) parts.push_back(r.source);
    if (std::find(targets.begin(), targets.end(), r.target) == targets.end()) {
      targets.push_back(r.target);
    }
  }
  if (!parts.empty()) {
    out << "\nTable II — cross-modal matrix: each part (rows) registered to each other full "
           "model (columns)\n";
    for (const auto& method : methods) {
      int ok = 0, total = 0, accurate = 0, refused = 0;
      std::ostringstream table;
      table << "\n" << method << "\n\n| part \\ model |";
      for (const auto& t : targets) table << ' ' << t << " |";
      table << "\n|---|";
      for (size_t i = 0; i < targets.size(); ++i) table << "---|";
      table << '\n';
      for (const auto& p : parts) {
        table << "| " << p << " |";
        for (const auto& t : targets) {
          std::string c = "–";
          for (const EvalRow& r : eval.rows) {
            if (r.experiment == "cross-modal" && r.source == p && r.target == t &&
                r.method == method) {
              c = CellText(r);
              ++total;
              // A success is a pose the method gave (ok, or the paper's unverified best)
              // within the threshold; a pose it refused is counted apart.
              const bool given = r.status != "failed";
              ok += given && r.success ? 1 : 0;
              accurate += given && r.accurate ? 1 : 0;
              refused += !given && r.success ? 1 : 0;
            }
          }
          table << ' ' << c << " |";
        }
        table << '\n';
      }
      out << table.str() << "\n" << method << ": " << ok << " of " << total
          << " succeeded, " << accurate << " of " << total << " accurate (poses the method gave; "
          << refused << " more refused by the method at a pose within the success threshold).\n";
    }
  }
}

struct Cell {
  const EvalRow* first = nullptr;
  const EvalRow* best = nullptr;
  const EvalRow* chosen = nullptr;
  const EvalRow* reference = nullptr;  // the "from-truth" row, when run
  const EvalRow* closest = nullptr;    // any status: the method row nearest the truth
};

// The cells of the evaluation in the order of their first row; *wrong_ok counts the ok rows
// beyond the success threshold.
std::vector<Cell> GroupCells(const SceneEvaluation& eval, int* wrong_ok) {
  std::vector<Cell> cells;
  for (const EvalRow& r : eval.rows) {
    auto it = std::find_if(cells.begin(), cells.end(), [&](const Cell& c) {
      return c.first->experiment == r.experiment && c.first->source == r.source &&
             c.first->target == r.target;
    });
    if (it == cells.end()) it = cells.insert(cells.end(), Cell{&r});
    if (r.method == kFromTruth) {
      it->reference = &r;
      continue;
    }
    if (std::isfinite(r.rms_m) && (it->closest == nullptr || r.rms_m < it->closest->rms_m)) {
      it->closest = &r;
    }
    if (r.status != "ok") continue;
    *wrong_ok += r.success ? 0 : 1;
    if (it->best == nullptr || r.rms_m < it->best->rms_m) it->best = &r;
    if (it->chosen == nullptr || r.sigma_rms_m < it->chosen->sigma_rms_m) it->chosen = &r;
  }
  return cells;
}

// The counts and lists the best-per-cell table gathers for its summary.
struct BestTally {
  int registered = 0, refused = 0, chosen_registered = 0;
  int allowed = 0, allowed_registered = 0, allowed_refused_right = 0;
  std::ostringstream off, limited, missed;
  BestTally() {
    off << std::setprecision(3);
    limited << std::setprecision(3);
    missed << std::setprecision(3);
  }
};

// The reference's column of a cell: its RMS and status; whether the data and the checks allow
// the cell (reference ok and accurate) and, if so, why no method registered it.
void WriteReferenceColumn(const Cell& c, std::ostream& out, BestTally* t) {
  const EvalRow* ref = c.reference;
  if (ref == nullptr) {
    out << " – |";
    return;
  }
  if (std::isnan(ref->rms_m)) {
    out << " no pose, " << ref->status << " |";
  } else {
    out << ' ' << ref->rms_m << ", " << ref->status << " |";
  }
  if (ref->status == "ok" && ref->accurate) {
    ++t->allowed;
    if (c.best != nullptr && c.best->accurate) {
      ++t->allowed_registered;
      return;
    }
    // Search- or check-limited: the method row nearest the truth, and the first words of its
    // reason ("ambiguous", "pose not determined", ...).
    t->missed << (t->missed.tellp() > 0 ? "; " : "") << c.first->source << " → " << c.first->target;
    if (c.closest == nullptr) {
      t->missed << " (no method row with a pose)";
    } else {
      const EvalRow& n = *c.closest;
      t->missed << " (closest: " << n.method << " " << n.rms_m << " m " << n.status;
      if (!n.reason.empty()) t->missed << ", " << n.reason.substr(0, n.reason.find(':'));
      t->missed << ")";
      t->allowed_refused_right += n.accurate ? 1 : 0;  // (an accurate ok is the best)
    }
    return;
  }
  t->limited << (t->limited.tellp() > 0 ? "; " : "") << c.first->source << " → " << c.first->target << " ";
  if (std::isnan(ref->rms_m)) {
    t->limited << "no pose";
  } else {
    t->limited << ref->rms_m << " m " << ref->status;
  }
}

// One row of the best-per-cell table.
void WriteBestRow(const Cell& c, bool with_reference, std::ostream& out, BestTally* t) {
  out << "| " << c.first->experiment << " | " << c.first->source << " → " << c.first->target << " | ";
  if (c.best == nullptr) {
    out << "– (every method failed) | – | – | – | – |";
    ++t->refused;
  } else {
    out << c.best->method << " | " << c.best->rms_m << " | " << c.chosen->method << " | "
        << c.chosen->sigma_rms_m << " | " << c.chosen->rms_m << " |";
    t->chosen_registered += c.chosen->accurate ? 1 : 0;
    if (c.best->accurate) {
      ++t->registered;
    } else {
      t->off << (t->off.tellp() > 0 ? "; " : "") << c.first->source << " → " << c.first->target
             << " " << c.best->rms_m << " m";
    }
  }
  if (with_reference) WriteReferenceColumn(c, out, t);
  out << "\n";
}

// The summary under the best-per-cell table.
void WriteBestSummary(const SceneEvaluation& eval, size_t num_cells, int wrong_ok, bool with_reference,
                      BestTally& t, std::ostream& out) {
  out << "\nRegistered with the best method (ok and RMS < " << eval.accurate_m
      << " m): " << t.registered << " of " << num_cells << " cells; every method failed: "
      << t.refused << "; best ok but RMS ≥ " << eval.accurate_m << " m: "
      << num_cells - t.registered - t.refused << (t.off.tellp() > 0 ? " (" + t.off.str() + ")" : "")
      << "; wrong ok (any method, RMS ≥ " << eval.success_threshold_m << " m): " << wrong_ok
      << ".\nRegistered with the method chosen by its stated σ (ok and RMS < " << eval.accurate_m
      << " m): " << t.chosen_registered << " of " << num_cells << " cells.\n";
  if (with_reference) {
    out << "From the truth (the reference, searched within " << eval.truth_window_m << " m / "
        << eval.truth_window_deg << "° of it): ok and RMS < " << eval.accurate_m << " m in "
        << t.allowed << " of " << num_cells
        << " cells — what the data and the checks allow; of those, registered with the best "
           "method: "
        << t.allowed_registered;
    if (t.missed.tellp() > 0) {
      out << "; not registered by any method (search- or check-limited; "
          << t.allowed_refused_right << " of them refused at a pose within " << eval.accurate_m
          << " m): " << t.missed.str();
    }
    out << ". Not registered even from the truth (data- or check-limited): "
        << (t.limited.tellp() > 0 ? t.limited.str() : std::string("none")) << ".\n";
  }
}

// The best method per cell ("registered ... with the best method"): of the
// methods that reported ok, the one closest to the ground truth. A cell counts as
// registered when that one is accurate; a method that reported ok beyond the success
// threshold is a wrong ok, counted on its own. Choosing by the truth is an evaluation's
// privilege; a user has only the results' own words, so the table also gives the ok a
// user would take — the one with the smallest stated uncertainty (sigma_rms_m) — and
// whether it is accurate.
void WriteBestPerCell(const SceneEvaluation& eval, std::ostream& out) {
  int wrong_ok = 0;
  const std::vector<Cell> cells = GroupCells(eval, &wrong_ok);
  if (cells.empty()) return;
  const bool with_reference = std::any_of(cells.begin(), cells.end(), [](const Cell& c) {
    return c.reference != nullptr;
  });
  BestTally tally;
  out << "\nBest method per cell — of the methods that reported ok, the one closest to the "
         "ground truth; and the one chosen without it, by the smallest stated sigma_rms_m"
      << (with_reference ? "; and the reference started at the truth (from-truth: RMS m, "
                           "status; no method a user has)"
                         : "")
      << "\n\n| experiment | source → target | best | RMS m | chosen by σ | its σ m | its RMS m |"
      << (with_reference ? " from the truth |" : "") << "\n|---|---|---|---|---|---|---|"
      << (with_reference ? "---|" : "") << "\n";
  for (const Cell& c : cells) WriteBestRow(c, with_reference, out, &tally);
  WriteBestSummary(eval, cells.size(), wrong_ok, with_reference, tally, out);
}

}  // namespace

void WriteSceneEvaluation(const SceneEvaluation& eval, const std::string& out_dir) {
  AtomicFileSet files;
  files.Add(fs::path(out_dir) / "results.csv", [&](std::ostream& out) { WriteResultsCsv(eval, out); });
  files.Add(fs::path(out_dir) / "tables.md", [&](std::ostream& out) {
    const std::vector<std::string> methods = MethodsOf(eval);
  out << std::setprecision(3);
  out << "Scene `" << eval.dir << "`: extent " << eval.extent_m
      << " m; success = RMS to ground truth < " << eval.success_threshold_m
      << " m (Kim & Hilton: 3 m on the 30 m Cathedral, scaled); accurate = RMS < "
      << eval.accurate_m << " m. Cell: RMS m, ✓ success / ✗ failure, "
      << "(status failed = the method itself reported failure; ok: the pose resolution it "
         "states), runtime s.\n\n";
    WriteTableI(eval, methods, out);
    WriteTableII(eval, methods, out);
    WriteBestPerCell(eval, out);
  });
  files.Commit();
}

}  // namespace mmba::registration
