<drawing><stroke><pt><x>0.1</x><y>0.1</y></pt></stroke></drawing>
