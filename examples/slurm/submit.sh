#!/bin/bash
# Submit the shard array, then the merge job that waits for all of it.
#   CITY=city.geojson ./submit.sh
set -euo pipefail
cd "$(dirname "$0")"
bake=$(sbatch --parsable bake.sbatch)
sbatch --dependency=afterok:"${bake%%;*}" merge.sbatch
