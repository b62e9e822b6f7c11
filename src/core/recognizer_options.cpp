#include "bsf_vpr/core/recognizer_options.h"

namespace bsf_vpr {

void RecognizerOptions::Validate() const {
  method_options.Validate();
  first_stage.Validate();
  calibration.Validate();
}

const OptionTable<RecognizerOptions>& RecognizerOptionsTable() {
  static const OptionTable<RecognizerOptions> kTable =
      OptionTable<RecognizerOptions>()
          .Add(
              "method", [](auto& o) -> auto& { return o.method; },
              "bsf, bayes_full, med, med_selective, nn:<set> or bayes:<set>, or one of the "
              "descriptor-level methods mean_descriptor, union_nn, subspace, discriminant "
              "(sets of one descriptor that share places), optionally with +filter "
              "(temporal filter prior; the Bayesian ones) and/or +seq (sequence matching)",
              "", {}, /*live=*/true)
          .Include(
              MethodOptionsTable(), [](auto& o) -> auto& { return o.method_options; })
          .Include(
              FirstStageOptionsTable(), [](auto& o) -> auto& { return o.first_stage; })
          .Include(
              CalibrationOptionsTable(), [](auto& o) -> auto& { return o.calibration; });
  return kTable;
}

}  // namespace bsf_vpr
