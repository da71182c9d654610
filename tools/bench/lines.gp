# visgate bench charts: one line (or point) series per method, drawn as PNG and SVG.
# Called by tools/bench/report.cpp as
#   gnuplot -e "dat='d.dat'; out='base'; ttl='...'; xl='x (unit)'; yl='y (unit)'; \
#               names='embree brute'; logx=1; logy=1" lines.gp
# `dat` holds one block per series (blocks separated by two blank lines), columns
# x, y and a quoted point label; `names` lists the series in block order, one legend
# entry each. Writes out.png (pngcairo when this gnuplot has it, else png) and out.svg.

if (!exists("logx")) logx = 0
if (!exists("logy")) logy = 0
if (!exists("ttl")) ttl = ""

set title ttl noenhanced
set xlabel xl noenhanced
set ylabel yl noenhanced
set key outside right top noenhanced
set grid xtics ytics mxtics mytics lc rgb "#dddddd"
if (logx) { set logscale x; set format x "10^{%L}" }
if (logy) { set logscale y; set format y "10^{%L}" }
set pointsize 1.2
set offsets graph 0.04, graph 0.04, graph 0.06, graph 0.06

n = words(names)
pl = "plot for [i=1:n] dat index (i-1) using 1:2 with linespoints lw 2 pt (i+5) title word(names, i), " . \
     "for [i=1:n] dat index (i-1) using 1:2:3 with labels offset 0.8,0.6 font ',8' notitle"

if (strstrt(GPVAL_TERMINALS, "pngcairo") > 0) {
  set terminal pngcairo size 1000,640 enhanced font ",11"
} else {
  set terminal png size 1000,640 enhanced
}
set output out.".png"
eval pl
set output

set terminal svg size 1000,640 enhanced font "Arial,12" background rgb "white"
set output out.".svg"
eval pl
set output
