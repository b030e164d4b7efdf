# Re-draw with: gnuplot calibrate_bench.gp
set terminal pngcairo size 1300,850 noenhanced font 'sans,10'
set output "calibrate_bench.png"
set datafile separator ','
set title "bench calibrate: 30 views of a synthetic flat board (seed 7), true lens LENSMODEL_OPENCV8 640x480 (StrongOpencv8Lens); median of 3 runs\nIntel(R) Xeon(R) Processor, 2 cores, build RelWithDebInfo, 2026-11-22 05:00 UTC"
set logscale xy
set xlabel 'median calibration time (s): mrcal seed + solve + uncertainty, Python start included'
set ylabel 'projection error vs the true lens, RMS over the imager (px)'
set grid xtics ytics mxtics mytics lc rgb '#dddddd'
set key outside right top
set format y '%g'
plot \
  'calibrate_bench.csv' skip 1 using 4:8 with points pt 7 ps 1.6 lc rgb '#1f77b4' title 'recovered - truth', \
  'calibrate_bench.csv' skip 1 using 4:13 with points pt 6 ps 1.6 lc rgb '#2ca02c' title 'reported sigma (RMS)', \
  'calibrate_bench.csv' skip 1 using 4:8:1 with labels offset 0.8,0.7 left font ',9' notitle, \
  '< grep ",1$" calibrate_bench.csv | sort -t, -k4 -g' using 4:8 with lines lw 2 lc rgb '#cc0000' title 'Pareto front'

unset output
