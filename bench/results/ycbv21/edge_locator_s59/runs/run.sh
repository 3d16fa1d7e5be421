#!/bin/bash
cd /work/main
O=OUT
B="python bench/bench_edge_pull.py --dataset ../shared/data/ycbv --suite-root /tmp/suite/full"
run() { n=$1; shift; [ -f $O/$n/edge_pull.csv ] || $B --out $O/$n "$@" > $O/$n.log 2>&1; }
F4=0,50,100,150
# pudding about y (long-2): the image and the locator
run pud_y_canny --clip long-2 --obj 7 --axis y --frames 0,50
run pud_y_self_canny --clip long-2 --obj 7 --axis y --frames 0,50 --self
run pud_y_self_ridge --clip long-2 --obj 7 --axis y --frames 0,50 --self --ridge
run pud_y_emis_canny --clip long-2 --obj 7 --axis y --frames 0,50 --images EMISSION_ROOT
run pud_y_emis_ridge --clip long-2 --obj 7 --axis y --frames 0,50 --images EMISSION_ROOT --ridge
run pud_y_emis_ridge_a2 --clip long-2 --obj 7 --axis y --frames 0,50 --images EMISSION_ROOT --ridge --area 2
run pud_y_emis_ridge_a4 --clip long-2 --obj 7 --axis y --frames 0,50 --images EMISSION_ROOT --ridge --area 4
run pud_y_amb_ridge_a4 --clip long-2 --obj 7 --axis y --frames 0,50 --images AMBIENT_ROOT --ridge --area 4
run pud_y_ridge_a4 --clip long-2 --obj 7 --axis y --frames 0,50 --ridge --area 4
run pud_y_ridge_a2_lit --clip long-2 --obj 7 --axis y --frames 0,50 --ridge --area 2 --lit
# the four long misses, four frames each
for spec in "long-2 7 y" "long-2 7 z" "long-1 8 y" "long-1 10 y" "long-3 20 x"; do
  set -- $spec
  for v in "canny:" "ridge:--ridge" "ridge_a2:--ridge --area 2" "ridge_a2_lit:--ridge --area 2 --lit"; do
    n=${v%%:*}; o=${v#*:}
    run obj${2}_${1}_${3}_$n --clip $1 --obj $2 --axis $3 --frames $F4 $o
  done
done
echo done
