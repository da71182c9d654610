# Stability chart of `visgate gate` (issue 4): per method, the rate of disagreements with
# the exact oracle per margin decade (disagreements / non-degenerate relations whose
# oracle margin lies in that decade). Input: the CSV written by the gate,
#   method,decade_index,decade,relations,disagreements,rate
# Usage: gnuplot -e "csv='stability.csv'; out='stability'; methods='embree brute ...'" plot_stability.gp
# writes out.png and out.svg. Decades without relations are left out; a rate of 0 is
# drawn at the floor 1e-7 so robust methods stay visible on the log axis.
if (!exists("csv")) csv = 'stability.csv'
if (!exists("out")) out = 'stability'
if (!exists("methods")) methods = 'embree embree-robust brute'
set datafile separator ','
set key outside right top
set logscale y
set yrange [5e-8:2]
set xrange [-0.5:13.5]
set xlabel 'oracle margin (relative to the scene diagonal), decade'
set ylabel 'disagreement rate'
set title 'visgate gate: disagreements with the exact oracle per margin decade'
set grid ytics
set format y '%.0e'
set xtics rotate by -45 ('<1e-12' 0, '1e-12' 1, '1e-11' 2, '1e-10' 3, '1e-9' 4, '1e-8' 5, '1e-7' 6, '1e-6' 7, \
    '1e-5' 8, '1e-4' 9, '1e-3' 10, '1e-2' 11, '1e-1' 12, '>=1' 13)
rate(m) = (strcol(1) eq m && $4 > 0) ? ($6 > 1e-7 ? $6 : 1e-7) : NaN
do for [fmt in 'png svg'] {
  if (fmt eq 'png') { set terminal pngcairo size 1000,600 noenhanced } else { set terminal svg size 1000,600 noenhanced }
  set output out.'.'.fmt
  plot for [i=1:words(methods)] csv skip 1 using 2:(rate(word(methods, i))) with linespoints lw 2 pt i title word(methods, i)
  unset output
}
