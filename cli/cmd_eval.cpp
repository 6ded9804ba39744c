// aniso eval: fills a sample table's values from a material.
#include <cstdio>
#include <memory>

#include "cli/command.h"
#include "io/files/files.h"
#include "io/formats/material_io.h"
#include "io/formats/rgl_bsdf.h"
#include "io/formats/table.h"

namespace aniso::cli {

Command add_eval(CLI::App& app) {
  struct Args {
    std::string mat, table, out;
    bool force = false;
  };
  auto a = std::make_shared<Args>();
  auto* eval = app.add_subcommand("eval", "Fill in a sample table (CSV) by evaluating a material");
  eval->add_option("MATERIAL", a->mat,
                   "material file, or a measured BRDF of the RGL material database (.bsdf: its "
                   "values as the database's own reader gives them, f_r cos theta_L)")
      ->required();
  eval->add_option("--table", a->table,
                   "sample table: theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg[,s][,u,v] (u, v: "
                   "where on the sample, for a material with maps)")
      ->required();
  eval->add_option("--out", a->out, "table to write with r,g,b ('-' = standard output)")
      ->required();
  add_force_flag(eval, &a->force);
  return {eval, [a] {
            if (is_rgl_bsdf(a->mat)) {
              const RglBsdf b = RglBsdf::read(a->mat);
              SampleTable t = read_table(a->table);
              check_outputs_apart({a->out}, {a->mat, a->table});
              check_output_file(a->out, OutputKind::kTable, a->force);
              evaluate_table(b, &t);
              write_table(a->out, t);
              std::fprintf(stderr, "eval: %zu rows of %s (%s) -> %s\n", t.rows.size(),
                           a->mat.c_str(), b.description().c_str(), a->out.c_str());
              return 0;
            }
            const Material m = read_material(a->mat);
            SampleTable t = read_table(a->table);
            if (!t.has_uv) note_material_maps(m, "eval (a table without u, v columns)");
            check_outputs_apart({a->out}, {a->mat, a->table});
            check_output_file(a->out, OutputKind::kTable, a->force);
            evaluate_table(m, &t);
            write_table(a->out, t);
            // The table may be on standard output: the summary goes to the error stream.
            std::fprintf(stderr, "eval: %zu rows -> %s\n", t.rows.size(), a->out.c_str());
            return 0;
          }};
}

}  // namespace aniso::cli
