<gml><tag><drawing>
  <stroke><pt><x>0.1</x><y>0.1</y></pt><pt><x>NaN</x><y>0.5</y></pt><pt><x>0.9</x><y>0.9</y></pt></stroke>
</drawing></tag></gml>
