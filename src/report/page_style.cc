// The style sheet of report.html (html_internal.h): A4 print layout, tables, verdict badges.
#include "report/html_internal.h"

namespace mmba::report::internal {

const char* const kCss = R"CSS(
@page { size: A4; margin: 14mm 12mm; }
* { box-sizing: border-box; }
body { font-family: "DejaVu Sans", Arial, Helvetica, sans-serif; font-size: 10pt; color: #1d1d1d;
       background: #ffffff; max-width: 190mm; margin: 0 auto; padding: 14px 10px 30px; line-height: 1.35; }
.kicker { color: #555; font-size: 9pt; letter-spacing: 0.04em; text-transform: uppercase; }
h1 { font-size: 18pt; margin: 2px 0 8px; }
h2 { font-size: 13pt; border-bottom: 2px solid #1f5fa8; padding-bottom: 2px; margin: 22px 0 8px;
     break-after: avoid; page-break-after: avoid; }
h3 { font-size: 11pt; margin: 12px 0 4px; break-after: avoid; }
table { border-collapse: collapse; margin: 4px 0 10px; font-size: 8.5pt; }
th, td { border: 1px solid #c8c8c8; padding: 2px 5px; vertical-align: top; }
th { background: #eef2f7; text-align: center; font-weight: 600; }
td.num { text-align: right; white-space: nowrap; font-variant-numeric: tabular-nums; }
tr { break-inside: avoid; page-break-inside: avoid; }
tr.flag td { background: #fde2e1; }
tr.rms td { font-weight: bold; background: #f3f3f3; }
table.meta th { text-align: left; background: #f6f6f6; width: 40mm; white-space: nowrap; }
table.meta { font-size: 9.5pt; }
.badge { display: inline-block; padding: 1px 9px; border-radius: 3px; color: #fff; font-weight: bold; }
.ok { background: #1a7f37; } .bad { background: #c62828; } .warn { background: #b26a00; }
.banner { border: 2px solid #c62828; background: #fdecea; padding: 6px 10px; margin: 8px 0; font-weight: bold; }
.summary { border: 2px solid #1f5fa8; border-radius: 4px; padding: 8px 12px; margin: 10px 0;
           break-inside: avoid; page-break-inside: avoid; }
.summary table { border: none; margin: 0; font-size: 10pt; }
.summary th, .summary td { border: none; padding: 2px 8px 2px 0; text-align: left; }
.summary th { background: none; font-weight: normal; color: #444; white-space: nowrap; }
.verdict { font-weight: bold; padding: 1px 8px; border-radius: 3px; color: #fff; }
.verdict.pass { background: #1a7f37; } .verdict.fail { background: #c62828; } .verdict.none { background: #777; }
.note { color: #555; font-size: 8.5pt; }
.plots { display: flex; flex-wrap: wrap; gap: 6px 14px; }
.plots figure { flex: 0 0 335px; width: 335px; }
figure { margin: 4px 0; break-inside: avoid; page-break-inside: avoid; }
figcaption { font-size: 8.5pt; color: #333; max-width: 100%; }
svg.plot { max-width: 100%; height: auto; display: block; }
ul.warnings li { margin: 2px 0; }
.caution { border-left: 4px solid #c62828; background: #fdecea; padding: 4px 10px; margin: 6px 0; }
.caution ul { margin: 2px 0 2px 16px; padding: 0; }
details summary { cursor: pointer; color: #1f5fa8; margin: 4px 0; }
pre.wrap { white-space: pre-wrap; word-break: break-all; font-size: 7.5pt; margin: 2px 0; }
section.warnings { border-left: 4px solid #b26a00; background: #fff7e6; padding: 2px 10px 4px; margin: 10px 0; }
section.warnings h2 { border: none; margin-top: 6px; }
code { font-family: "DejaVu Sans Mono", monospace; font-size: 8.5pt; }
footer { margin-top: 24px; color: #777; font-size: 8pt; border-top: 1px solid #ccc; padding-top: 4px; }
@media print { body { max-width: none; padding: 0; } details { display: none; } }
)CSS";

}  // namespace mmba::report::internal
